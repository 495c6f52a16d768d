#include "table/device_table.hpp"

#include <gtest/gtest.h>

using nlohmann::json;
using rsd::DeviceTable;
using rsd::EventType;

namespace {
json d455(const std::string& fw = "5.16.0.1") {
  return {{"name", "Intel RealSense D455"}, {"topic-root", "realsense/D455_1"}, {"fw-version", fw}};
}
}  // namespace

TEST(DeviceTable, AddThenFind) {
  DeviceTable t;
  auto ev = t.upsert("a", d455(), "T1");
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->type, EventType::added);
  EXPECT_EQ(ev->generation, 1u);
  const auto entry = t.find("a");
  ASSERT_NE(entry, nullptr);
  const json doc = entry->json();
  EXPECT_EQ(doc["id"], "a");
  EXPECT_EQ(doc["first-seen"], "T1");
  EXPECT_EQ(doc["last-seen"], "T1");
  EXPECT_EQ(doc["fw-version"], "5.16.0.1");
  // The typed device is the same document, read once.
  EXPECT_EQ(entry->device.id, "a");
  EXPECT_EQ(entry->device.fw_version, "5.16.0.1");
  EXPECT_EQ(entry->device.topic_root, "realsense/D455_1");
}

TEST(DeviceTable, ReannouncementOnlyMovesLastSeen) {
  DeviceTable t;
  t.upsert("a", d455(), "T1");
  EXPECT_FALSE(t.upsert("a", d455(), "T2"));
  EXPECT_EQ(t.generation(), 1u);
  EXPECT_EQ(t.find("a")->json()["first-seen"], "T1");
  EXPECT_EQ(t.find("a")->json()["last-seen"], "T2");
}

// What the daemon says of a camera without hearing it (unresponsive once its lease
// ran out, a client came) is a change, but last-seen stays when it was last heard.
TEST(DeviceTable, AChangeNotHeardFromTheCameraKeepsLastSeen) {
  DeviceTable t;
  t.upsert("a", d455(), "T1");
  json marked = d455();
  marked["unresponsive"] = true;
  auto ev = t.upsert("a", marked, "T2", /*heard=*/false);
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->type, EventType::changed);
  EXPECT_EQ(t.find("a")->json()["unresponsive"], true);
  EXPECT_EQ(t.find("a")->json()["last-seen"], "T1");
  EXPECT_TRUE(t.upsert("a", d455(), "T3"));  // heard again: unmarked, and seen now
  EXPECT_EQ(t.find("a")->json()["last-seen"], "T3");
  EXPECT_FALSE(t.find("a")->json().contains("unresponsive"));
}

TEST(DeviceTable, ChangedFieldEmitsChangedAndKeepsFirstSeen) {
  DeviceTable t;
  t.upsert("a", d455(), "T1");
  json recovering = d455();
  recovering["recovery"] = true;
  auto ev = t.upsert("a", recovering, "T2");
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->type, EventType::changed);
  EXPECT_EQ(ev->device()["recovery"], true);
  EXPECT_EQ(ev->device()["first-seen"], "T1");
  EXPECT_EQ(t.size(), 1u);
}

TEST(DeviceTable, RemoveKnownAndUnknown) {
  DeviceTable t;
  t.upsert("a", d455(), "T1");
  EXPECT_FALSE(t.remove("nope", rsd::model::RemovalReason::stopping, "T9"));
  auto ev = t.remove("a", rsd::model::RemovalReason::stopping, "T9");
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->type, EventType::removed);
  EXPECT_EQ(ev->device()["id"], "a");
  EXPECT_EQ(t.find("a"), nullptr);
  EXPECT_EQ(t.generation(), 2u);
}

TEST(DeviceTable, RemoveIfRemovesOnlyMatches) {
  DeviceTable t;
  t.upsert("a", {{"domain", 1}}, "T");
  t.upsert("b", {{"domain", 2}}, "T");
  t.upsert("c", {{"domain", 1}}, "T");
  auto events = t.remove_if([](const rsd::model::Device& d) { return d.domain == 1; }, rsd::model::RemovalReason::domain_left, "T9");
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(t.size(), 1u);
  EXPECT_NE(t.find("b"), nullptr);
}

TEST(DeviceTable, DevicesAreOrderedById) {
  DeviceTable t;
  t.upsert("b", json::object(), "T");
  t.upsert("a", json::object(), "T");
  auto all = t.devices();
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0]["id"], "a");
  EXPECT_EQ(all[1]["id"], "b");
}

TEST(DeviceTable, ResumeReturnsEveryMissedEventInOrder) {
  DeviceTable t;
  t.upsert("a", json::object(), "T");  // 1
  t.upsert("b", json::object(), "T");  // 2
  t.remove("a", rsd::model::RemovalReason::stopping, "T9");                         // 3
  auto since = t.events_since(1);
  EXPECT_FALSE(since.gap);
  ASSERT_EQ(since.events.size(), 2u);
  EXPECT_EQ(since.events[0].generation, 2u);
  EXPECT_EQ(since.events[0].type, EventType::added);
  EXPECT_EQ(since.events[1].generation, 3u);
  EXPECT_EQ(since.events[1].type, EventType::removed);
  EXPECT_TRUE(t.events_since(3).events.empty());
  EXPECT_FALSE(t.events_since(3).gap);
  EXPECT_EQ(t.events_since(0).events.size(), 3u);
}

TEST(DeviceTable, ResumeTooFarBehindIsAGap) {
  DeviceTable t(2);
  for (int i = 0; i < 5; ++i) t.upsert("d" + std::to_string(i), json::object(), "T");
  EXPECT_TRUE(t.events_since(1).gap);   // generations 2 and 3 fell out of the log
  EXPECT_FALSE(t.events_since(3).gap);  // 4 and 5 are still there
  EXPECT_EQ(t.events_since(3).events.size(), 2u);
}

TEST(DeviceTable, GenerationFromTheFutureIsAGap) {
  DeviceTable t;
  t.upsert("a", json::object(), "T");
  EXPECT_TRUE(t.events_since(99).gap);
}

TEST(DeviceTable, FirstGenerationSeedsIds) {
  DeviceTable t(16, 1000);
  EXPECT_EQ(t.upsert("a", json::object(), "T")->generation, 1001u);
  EXPECT_TRUE(t.events_since(10).gap);  // an id from before this table existed
  EXPECT_EQ(t.events_since(1000).events.size(), 1u);
}

TEST(DeviceTable, DescribedIsAnEventThatChangesNothing) {
  DeviceTable t;
  t.upsert("a", d455(), "T1");
  const json before = t.find("a")->json();
  auto ev = t.note_described("a");
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->type, EventType::described);
  EXPECT_STREQ(rsd::to_string(ev->type), "described");
  EXPECT_EQ(ev->generation, 2u);
  EXPECT_EQ(ev->device(), before);
  EXPECT_EQ(t.find("a")->json(), before);
  EXPECT_EQ(t.events_since(1).events.size(), 1u);
  EXPECT_FALSE(t.note_described("nobody"));
  EXPECT_EQ(t.generation(), 2u);
}

TEST(DeviceTable, TheLogIsBoundedInBytesTooAndKeepsTheNewest) {
  // 4 KiB of documents at most: a burst of large documents cannot grow the daemon.
  DeviceTable t(4096, 0, 4096);
  const json big = {{"name", std::string(1000, 'x')}};
  for (int i = 0; i < 20; ++i) t.upsert("d" + std::to_string(i), big, "T");
  EXPECT_TRUE(t.events_since(0).gap);
  const auto kept = t.events_since(t.generation() - 3);
  EXPECT_FALSE(kept.gap);
  ASSERT_EQ(kept.events.size(), 3u);
  EXPECT_EQ(kept.events.back().id, "d19");
  EXPECT_EQ(kept.events.back().device()["name"], big["name"]);
  EXPECT_TRUE(t.events_since(t.generation() - 5).gap);  // about four fit
  // One document larger than the whole bound is still kept, alone.
  t.upsert("huge", {{"name", std::string(10000, 'y')}}, "T");
  EXPECT_FALSE(t.events_since(t.generation() - 1).gap);
  EXPECT_TRUE(t.events_since(t.generation() - 2).gap);
}

TEST(DeviceTable, AnEntryIsTypedAndSerializedOncePerChange) {
  DeviceTable t;
  const auto added = t.upsert("a", d455(), "T1");
  const auto entry = t.find("a");
  ASSERT_TRUE(added && entry);
  // The event, the table and every reader share one entry: no copy, no second dump.
  EXPECT_EQ(added->entry.get(), entry.get());
  EXPECT_EQ(t.entries().at(0).get(), entry.get());
  EXPECT_EQ(entry->text, entry->json().dump());
  EXPECT_EQ(entry->device.name, "Intel RealSense D455");
  EXPECT_EQ(entry->device.first_seen, "T1");
  // A change makes a new entry; the log keeps the old one as it was.
  json recovering = d455();
  recovering["recovery"] = true;
  ASSERT_TRUE(t.upsert("a", recovering, "T2"));
  EXPECT_NE(t.find("a").get(), entry.get());
  EXPECT_EQ(t.find("a")->device.recovery, true);
  EXPECT_FALSE(entry->device.recovery);
  EXPECT_EQ(t.events_since(0).events.at(0).entry.get(), entry.get());
}

TEST(DeviceTable, TheTextReplacesInvalidUtf8AndTheTypedDeviceKeepsIt) {
  DeviceTable t;
  t.upsert("a", {{"name", std::string("D455\xff")}}, "T");
  EXPECT_EQ(t.find("a")->device.name, std::string("D455\xff"));
  EXPECT_NE(t.find("a")->text.find("\"D455\xef\xbf\xbd\""), std::string::npos);  // U+FFFD
}

TEST(DeviceTable, ATypedSightingMakesTheEntryItsJsonWould) {
  // A DDS source hands the table its model::Device, USB its JSON: one entry either way.
  // Keys the table owns are its own however a source spells them.
  json doc = d455();
  doc["first-seen"] = 5;
  doc["sources"] = "usb";
  doc["merged-into"] = json::array();
  doc["reason"] = "stopping";
  doc["source"] = "dds";
  DeviceTable by_json, typed;
  by_json.upsert("a", doc, "T1");
  typed.upsert("a", rsd::model::device_from_json(doc), "T1");
  EXPECT_EQ(typed.find("a")->text, by_json.find("a")->text);
  const json entry = typed.find("a")->json();
  EXPECT_EQ(entry["first-seen"], "T1");
  EXPECT_EQ(entry["sources"], json::array({"dds"}));
  EXPECT_FALSE(entry.contains("merged-into"));
  EXPECT_FALSE(entry.contains("reason"));
  // The same device again is no change, typed as well.
  EXPECT_FALSE(typed.upsert("a", rsd::model::device_from_json(doc), "T2"));
  EXPECT_EQ(typed.find("a")->device.last_seen, "T2");
}
