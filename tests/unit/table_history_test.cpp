// The table's memory of cameras that changed or left: removal reasons on events,
// gone entries found by id, serial or topic-root, per-camera history and its bounds.
#include "table/device_table.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

using nlohmann::json;
using rsd::DeviceTable;
using rsd::EventType;
using rsd::HistoryLimits;
using rsd::model::RemovalReason;

namespace {
json camera(const std::string& serial) {
  return {{"name", "Intel RealSense D455"}, {"serial", serial}, {"topic-root", "realsense/D455_" + serial}};
}
}  // namespace

TEST(RemovalReason, EverySpellingReadsBack) {
  std::set<std::string> names;
  for (RemovalReason r : rsd::model::kRemovalReasons) {
    const std::string name(rsd::model::to_string(r));
    EXPECT_EQ(rsd::model::parse_removal_reason(name), r);
    names.insert(name);
  }
  EXPECT_EQ(names, (std::set<std::string>{"stopping", "writer-gone", "lease-expired", "unplugged", "interface-gone",
                                          "domain-left", "refused"}));
  EXPECT_FALSE(rsd::model::parse_removal_reason("Stopping"));
}

TEST(TableHistory, RemovedCameraIsGoneWithReasonLastDocumentAndLastSeen) {
  DeviceTable t;
  t.upsert("a", camera("111"), "T1");
  t.upsert("a", camera("111"), "T2");  // a re-announcement moves last-seen only
  const auto ev = t.remove("a", RemovalReason::lease_expired, "T3", "its participant is gone");
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->type, EventType::removed);
  EXPECT_EQ(ev->reason, RemovalReason::lease_expired);
  EXPECT_EQ(t.find("a"), nullptr);
  for (const std::string key : {"a", "111", "realsense/D455_111"}) {
    const auto gone = t.find_gone(key);
    ASSERT_TRUE(gone) << key;
    EXPECT_EQ(gone->reason, RemovalReason::lease_expired);
    EXPECT_EQ(gone->removed_at, "T3");
    EXPECT_EQ(gone->detail, "its participant is gone");
    EXPECT_EQ(gone->last->device.id, "a");
    EXPECT_EQ(gone->last->device.last_seen, "T2");
    EXPECT_EQ(gone->generation, ev->generation);
  }
  EXPECT_FALSE(t.find_gone("never-seen"));
  EXPECT_FALSE(t.history("never-seen"));
  t.upsert("b", camera("222"), "T4");
  EXPECT_FALSE(t.find_gone("b"));  // present, not gone
}

TEST(TableHistory, CameraBackAfterAwaySaysSoAndIsNoLongerGone) {
  DeviceTable t;
  const auto first = t.upsert("a", camera("111"), "T1");
  ASSERT_TRUE(first);
  EXPECT_FALSE(first->back);
  EXPECT_EQ(first->away_since, "");
  t.remove("a", RemovalReason::unplugged, "T2");
  const auto again = t.upsert("a", camera("111"), "T3");
  ASSERT_TRUE(again);
  EXPECT_EQ(again->type, EventType::added);
  EXPECT_TRUE(again->back);
  EXPECT_EQ(again->away_since, "T2");
  EXPECT_FALSE(t.find_gone("a"));
  EXPECT_EQ(t.gone_size(), 0u);

  const auto h = t.history("111");  // by serial, while present
  ASSERT_TRUE(h);
  EXPECT_EQ(h->id, "a");
  ASSERT_EQ(h->changes.size(), 3u);
  EXPECT_EQ(h->changes[0].type, EventType::added);
  EXPECT_FALSE(h->changes[0].back);
  EXPECT_EQ(h->changes[0].at, "T1");
  EXPECT_EQ(h->changes[1].type, EventType::removed);
  EXPECT_EQ(h->changes[1].reason, RemovalReason::unplugged);
  EXPECT_EQ(h->changes[1].at, "T2");
  EXPECT_EQ(h->changes[2].type, EventType::added);
  EXPECT_TRUE(h->changes[2].back);
  EXPECT_EQ(h->changes[2].id, "a");
  EXPECT_EQ(h->removed(RemovalReason::unplugged), 1u);
  EXPECT_EQ(h->removed(RemovalReason::lease_expired), 0u);
}

TEST(TableHistory, MergeIsNoDeparture) {
  DeviceTable t;
  json usb = camera("123");
  usb["source"] = "usb";
  json dds = camera("123");
  dds["source"] = "dds";
  t.upsert("usb-123", usb, "T1");
  t.upsert("dds-7-x", dds, "T2");  // the USB entry is removed into the DDS one
  const auto log = t.events_since(0).events;
  ASSERT_GE(log.size(), 2u);
  EXPECT_EQ(log[1].type, EventType::removed);
  EXPECT_FALSE(log[1].reason);
  EXPECT_FALSE(t.find_gone("usb-123"));
  // The DDS side leaving: the merged entry is gone, the USB one is listed again.
  const auto ev = t.remove("dds-7-x", RemovalReason::stopping, "T3");
  ASSERT_TRUE(ev);
  ASSERT_TRUE(t.find_gone("dds-7-x"));
  EXPECT_EQ(t.find_gone("dds-7-x")->reason, RemovalReason::stopping);
  EXPECT_NE(t.find("usb-123"), nullptr);
}

TEST(TableHistory, PerCameraBoundDropsTheOldestAndKeepsCounting) {
  DeviceTable t(4096, 0, 128 * 1024, HistoryLimits{4, 100, 10});
  for (int i = 0; i < 10; ++i) {
    t.upsert("a", camera("111"), "T" + std::to_string(i));
    t.remove("a", i % 2 ? RemovalReason::lease_expired : RemovalReason::writer_gone, "T" + std::to_string(i));
  }
  const auto h = t.history("a");
  ASSERT_TRUE(h);
  ASSERT_EQ(h->changes.size(), 4u);
  EXPECT_EQ(h->changes.front().at, "T8");  // the newest four: T8 added, removed, T9 added, removed
  EXPECT_EQ(h->changes.back().type, EventType::removed);
  EXPECT_EQ(h->removed(RemovalReason::lease_expired), 5u);
  EXPECT_EQ(h->removed(RemovalReason::writer_gone), 5u);
  EXPECT_EQ(t.history_size(), 4u);
}

TEST(TableHistory, TenThousandCamerasComingAndGoingStayWithinBounds) {
  const HistoryLimits limits{64, 2048, 256};
  DeviceTable t(4096, 0, 128 * 1024, limits);
  for (int round = 0; round < 2; ++round)
    for (int i = 0; i < 10000; ++i) {
      const std::string id = "cam-" + std::to_string(i), serial = std::to_string(1000000 + i);
      t.upsert(id, camera(serial), "T");
      t.remove(id, RemovalReason::lease_expired, "T");
      ASSERT_LE(t.history_size(), limits.total);
      ASSERT_LE(t.gone_size(), limits.gone);
    }
  EXPECT_EQ(t.gone_size(), limits.gone);
  EXPECT_EQ(t.size(), 0u);
  // The latest gone stay findable, the oldest were dropped first.
  EXPECT_TRUE(t.find_gone("cam-9999"));
  EXPECT_TRUE(t.find_gone("1009999"));
  EXPECT_FALSE(t.find_gone("cam-0"));
  EXPECT_FALSE(t.history("cam-0"));
  const auto latest = t.history("cam-9999");
  ASSERT_TRUE(latest);
  EXPECT_EQ(latest->changes.size(), 2u);
  // Between the rounds it was dropped from gone and history, and its counts with it.
  EXPECT_EQ(latest->removed(RemovalReason::lease_expired), 1u);
}

TEST(TableHistory, HistorySinceIsInOrderBoundedAndResumes) {
  DeviceTable t;
  t.upsert("a", camera("1"), "T1");
  t.upsert("b", camera("2"), "T2");
  t.remove("a", RemovalReason::stopping, "T3");
  json changed = camera("2");
  changed["fw-version"] = "5.17";
  t.upsert("b", changed, "T4");  // a change of fields is no change of presence
  t.remove("b", RemovalReason::writer_gone, "T5");
  const auto all = t.history_since(0, 100);
  ASSERT_EQ(all.size(), 4u);
  EXPECT_EQ(all[0].id, "a");
  EXPECT_EQ(all[1].id, "b");
  EXPECT_EQ(all[2].id, "a");
  EXPECT_EQ(all[2].reason, RemovalReason::stopping);
  EXPECT_EQ(all[3].reason, RemovalReason::writer_gone);
  for (std::size_t i = 1; i < all.size(); ++i) EXPECT_LT(all[i - 1].generation, all[i].generation);
  const auto first_two = t.history_since(0, 2);
  ASSERT_EQ(first_two.size(), 2u);
  const auto rest = t.history_since(first_two.back().generation, 100);
  ASSERT_EQ(rest.size(), 2u);
  EXPECT_EQ(rest[0].generation, all[2].generation);
  EXPECT_TRUE(t.history_since(all.back().generation, 100).empty());
}

TEST(TableHistory, GoneEntriesExpire) {
  DeviceTable t;
  t.upsert("a", camera("1"), "2026-01-01T00:00:00.000Z");
  t.remove("a", RemovalReason::stopping, "2026-01-01T00:00:01.000Z");
  t.upsert("b", camera("2"), "2026-01-01T00:00:02.000Z");
  t.remove("b", RemovalReason::stopping, "2026-01-01T00:00:03.000Z");
  t.expire_gone("2026-01-01T00:00:02.000Z");
  EXPECT_FALSE(t.find_gone("a"));
  EXPECT_TRUE(t.find_gone("b"));
  EXPECT_EQ(t.gone_size(), 1u);
}

TEST(TableHistory, LostByLeaseAndBackWithinAMinuteIsAFlap) {
  DeviceTable t;
  t.upsert("a", camera("1"), "2026-01-01T00:00:00.000Z");
  t.remove("a", RemovalReason::lease_expired, "2026-01-01T00:00:10.000Z");
  t.upsert("a", camera("1"), "2026-01-01T00:00:13.500Z");  // back 3.5 s later: a flap
  t.remove("a", RemovalReason::lease_expired, "2026-01-01T00:01:00.000Z");
  t.upsert("a", camera("1"), "2026-01-01T00:02:00.001Z");  // away over a minute: not one
  t.remove("a", RemovalReason::stopping, "2026-01-01T00:03:00.000Z");
  t.upsert("a", camera("1"), "2026-01-01T00:03:01.000Z");  // said it was stopping: not one
  const auto h = t.history("a");
  ASSERT_TRUE(h);
  EXPECT_EQ(h->flaps, 1u);
  EXPECT_EQ(t.counts().flaps, 1u);
  EXPECT_EQ(t.counts().returns, 3u);
  ASSERT_EQ(h->changes.size(), 7u);
  EXPECT_TRUE(h->changes[2].flap);
  EXPECT_FALSE(h->changes[4].flap);
  EXPECT_FALSE(h->changes[6].flap);
}

TEST(TableHistory, HostVerdictJoinsItsRemovalOnlyAndIsCounted) {
  using rsd::model::HostVerdict;
  DeviceTable t;
  t.upsert("a", camera("111"), "T1");
  const auto first = t.remove("a", RemovalReason::lease_expired, "T2");
  t.upsert("a", camera("111"), "T3");
  const auto second = t.remove("a", RemovalReason::lease_expired, "T4");
  ASSERT_TRUE(first && second);
  // A verdict on a removal the camera came back from is kept on that record alone.
  EXPECT_TRUE(t.judge_host("a", first->generation, HostVerdict::unreachable));
  EXPECT_FALSE(t.find_gone("a")->host);
  EXPECT_TRUE(t.judge_host("a", second->generation, HostVerdict::present));
  EXPECT_EQ(t.find_gone("a")->host, HostVerdict::present);
  const auto h = t.history("a");
  ASSERT_TRUE(h);
  ASSERT_EQ(h->changes.size(), 4u);
  EXPECT_EQ(h->changes[1].host, HostVerdict::unreachable);
  EXPECT_FALSE(h->changes[2].host);  // the addition
  EXPECT_EQ(h->changes[3].host, HostVerdict::present);
  EXPECT_FALSE(t.judge_host("never-seen", 1, HostVerdict::present));
  const auto counts = t.counts();
  EXPECT_EQ(counts.hosts[static_cast<std::size_t>(HostVerdict::present)], 2u);
  EXPECT_EQ(counts.hosts[static_cast<std::size_t>(HostVerdict::unreachable)], 1u);
}
