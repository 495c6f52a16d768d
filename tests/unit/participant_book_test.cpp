// ParticipantBook is who is on a domain, for /v1/participants and `doctor`:
// participants appear, change, are lost or leave, come back, and the book stays
// bounded. Driven with made-up sightings and times; DomainBook::publishers gives
// the device-info side, checked here with the same made-up writers.
#include "dds/domain_book.hpp"
#include "dds/participant_book.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include <string>

using namespace std::chrono_literals;
using rsd::dds::ParticipantBook;
using rsd::dds::ParticipantSighting;
using rsd::dds::PublisherCounts;
using rsd::model::ParticipantState;
using rsd::model::Vendor;

namespace {

ParticipantSighting fast_dds(int n) {
  ParticipantSighting s;
  s.guid = "010f" + std::to_string(1000 + n) + ".3e2482db.00000000.000001c1";
  s.name = "camera-" + std::to_string(n);
  s.addresses = {"192.0.2." + std::to_string(n)};
  s.lease_seconds = 3.0;
  return s;
}

ParticipantSighting cyclone(int n) {
  ParticipantSighting s;
  s.guid = "0110" + std::to_string(2000 + n) + ".a2cb9cf6.1994d528.000001c1";
  s.name = "py-cyclone";
  s.host = "lab-pc";
  s.process = "python";
  s.pid = 4242;
  s.lease_seconds = 10.0;
  return s;
}

}  // namespace

TEST(ParticipantBook, AliveParticipantsCarryVendorAndCounts) {
  ParticipantBook book;
  book.alive(fast_dds(1), "T1");
  book.alive(cyclone(1), "T2");
  const std::map<std::string, PublisherCounts> publishers = {{fast_dds(1).guid, {3, 2, 0, false, {"realsense/D455_1", "realsense/D455_2"}}}};
  const auto list = book.list(7, "T9", publishers);
  ASSERT_EQ(list.size(), 2u);
  const auto& camera = list[0].vendor == Vendor::fast_dds ? list[0] : list[1];
  const auto& other = list[0].vendor == Vendor::fast_dds ? list[1] : list[0];
  EXPECT_EQ(camera.domain, 7);
  EXPECT_EQ(camera.vendor_id, "01.0f");
  EXPECT_EQ(camera.name, "camera-1");
  EXPECT_EQ(camera.first_seen, "T1");
  EXPECT_EQ(camera.last_seen, "T9");  // alive: heard within its lease
  EXPECT_EQ(camera.device_info_writers, 3u);
  EXPECT_EQ(camera.devices, 2u);
  EXPECT_EQ(camera.topic_roots, (std::vector<std::string>{"realsense/D455_1", "realsense/D455_2"}));
  EXPECT_EQ(other.vendor, Vendor::cyclone_dds);
  EXPECT_EQ(other.host, "lab-pc");
  EXPECT_EQ(other.pid, 4242);
  EXPECT_EQ(other.device_info_writers, 0u);
}

TEST(ParticipantBook, AChangedAnnouncementKeepsFirstSeen) {
  ParticipantBook book;
  book.alive(fast_dds(1), "T1");
  auto renamed = fast_dds(1);
  renamed.name = "renamed";
  book.alive(renamed, "T5");
  const auto list = book.list(0, "T9", {});
  ASSERT_EQ(list.size(), 1u);
  EXPECT_EQ(list[0].name, "renamed");
  EXPECT_EQ(list[0].first_seen, "T1");
}

TEST(ParticipantBook, GoneOnesAreListedAfterTheAliveLatestFirst) {
  ParticipantBook book;
  book.alive(fast_dds(1), "T1");
  book.alive(fast_dds(2), "T1");
  book.alive(fast_dds(3), "T1");
  book.gone(fast_dds(1).guid, "T4");
  book.gone(fast_dds(2).guid, "T5");
  const auto list = book.list(0, "T9", {{fast_dds(1).guid, {2, 1, 0, false, {"realsense/D455_1"}}}});
  ASSERT_EQ(list.size(), 3u);
  EXPECT_EQ(list[0].state, ParticipantState::alive);
  EXPECT_EQ(list[1].guid, fast_dds(2).guid);
  EXPECT_EQ(list[1].state, ParticipantState::gone);
  EXPECT_EQ(list[1].last_seen, "T5");
  EXPECT_EQ(list[2].state, ParticipantState::gone);
  EXPECT_EQ(list[2].last_seen, "T4");
  EXPECT_EQ(list[2].device_info_writers, 0u);  // its writers went with it
}

TEST(ParticipantBook, OneComingBackIsListedOnceAsAliveWithANewFirstSeen) {
  ParticipantBook book;
  book.alive(fast_dds(1), "T1");
  book.gone(fast_dds(1).guid, "T2");
  book.alive(fast_dds(1), "T3");
  const auto list = book.list(0, "T9", {});
  ASSERT_EQ(list.size(), 1u);
  EXPECT_EQ(list[0].state, ParticipantState::alive);
  EXPECT_EQ(list[0].first_seen, "T3");
}

TEST(ParticipantBook, StaysBoundedWithEndlessNewPeers) {
  ParticipantBook book(/*max_alive=*/4, /*max_gone=*/3);
  for (int n = 0; n < 100; ++n) book.alive(fast_dds(n), "T");
  EXPECT_EQ(book.list(0, "T", {}).size(), 4u);
  EXPECT_EQ(book.unlisted(), 96u);
  for (int n = 0; n < 100; ++n) book.gone(fast_dds(n).guid, "T");
  EXPECT_EQ(book.unlisted(), 0u);
  const auto list = book.list(0, "T", {});
  ASSERT_EQ(list.size(), 3u);  // the latest gone only
  for (const auto& p : list) EXPECT_EQ(p.state, ParticipantState::gone);
}

TEST(ParticipantBook, ARebuiltParticipantForgetsTheAliveOnesOnly) {
  ParticipantBook book;
  book.alive(fast_dds(1), "T1");
  book.alive(fast_dds(2), "T1");
  book.gone(fast_dds(2).guid, "T2");
  book.participant_rebuilt();
  const auto list = book.list(0, "T9", {});
  ASSERT_EQ(list.size(), 1u);
  EXPECT_EQ(list[0].state, ParticipantState::gone);
}

TEST(ParticipantBook, EndpointsAreCountedPerParticipantAndKeptWhenItGoes) {
  ParticipantBook book;
  const auto p = fast_dds(1);
  const std::string prefix = p.guid.substr(0, 27);
  book.endpoint_alive(p.guid, prefix + "00000503", "topic", false, "T");  // before its participant: order does not matter
  book.alive(p, "T1");
  book.endpoint_alive(p.guid, prefix + "00000504", "topic", false, "T");
  book.endpoint_alive(p.guid, prefix + "00000504", "topic", false, "T");  // the same one again (a QoS change)
  book.alive(fast_dds(2), "T1");
  auto list = book.list(0, "T2", {});
  ASSERT_EQ(list.size(), 2u);
  for (const auto& x : list) EXPECT_EQ(x.endpoints, x.guid == p.guid ? 2u : 0u) << x.guid;
  book.endpoint_gone(p.guid, prefix + "00000503");
  book.gone(p.guid, "T3");
  list = book.list(0, "T4", {});
  const auto gone = std::find_if(list.begin(), list.end(), [&](const auto& x) { return x.guid == p.guid; });
  ASSERT_NE(gone, list.end());
  EXPECT_EQ(gone->endpoints, 2u);  // the most it had
}

TEST(ParticipantBook, OneThatEndedCleanlyKeepsWhatItHadExchanged) {
  // A program that ends cleanly (librealsense's query_devices(), a camera server
  // stopping) disposes its endpoints before its participant: gone, it still shows
  // it exchanged something, unlike one whose unicast never got through.
  ParticipantBook book;
  const auto p = fast_dds(1), walled = fast_dds(2);
  const std::string prefix = p.guid.substr(0, 27);
  book.alive(p, "T1");
  book.alive(walled, "T1");
  book.endpoint_alive(p.guid, prefix + "00000503", "topic", false, "T");
  book.endpoint_alive(p.guid, prefix + "00000504", "topic", false, "T");
  book.endpoint_gone(p.guid, prefix + "00000503");
  book.endpoint_gone(p.guid, prefix + "00000504");
  book.gone(p.guid, "T2");
  book.gone(walled.guid, "T2");
  for (const auto& x : book.list(0, "T3", {})) EXPECT_EQ(x.endpoints, x.guid == p.guid ? 2u : 0u) << x.guid;
  // Back after a while: it starts from what it exchanges now.
  book.alive(p, "T4");
  for (const auto& x : book.list(0, "T5", {})) {
    if (x.guid == p.guid) {
      EXPECT_EQ(x.endpoints, 0u);
    }
  }
}

TEST(DomainBookPublishers, CountsWritersDevicesAndSilence) {
  rsd::SharedTable table;
  rsd::dds::BookOptions options;
  options.domain = 7;
  rsd::dds::DomainBook book(table, options);
  const auto t0 = rsd::dds::DomainBook::Clock::time_point{};
  const auto identity = [](const std::string& participant, int n) {
    const std::string prefix = participant.substr(0, 27);
    return rsd::dds::WriterIdentity{prefix + "0000010" + std::to_string(n), participant, "server", {"192.0.2.1"}};
  };
  const std::string talking = "010f0001.aaaabbbb.00000000.000001c1";
  const std::string silent = "010f0002.aaaabbbb.00000000.000001c1";
  book.writer_matched(1, identity(talking, 1), t0);
  book.writer_matched(2, identity(talking, 2), t0);
  book.sample(1, rsd::dds::DeviceInfo{{{"name", "D455"}, {"topic-root", "realsense/D455_1"}}, "realsense/D455_1"});
  book.writer_matched(3, identity(silent, 1), t0);
  book.writer_matched(4, identity(silent, 2), t0);
  // Before the grace nobody is silent; after it, the server whose two writers
  // never wrote has never announced; the other's idle writer is just idle.
  auto counts = book.publishers(t0 + 1s);
  EXPECT_EQ(counts[silent].silent, 0u);
  EXPECT_FALSE(counts[silent].never_announced);
  counts = book.publishers(t0 + 10s);
  EXPECT_EQ(counts[talking].writers, 2u);
  EXPECT_EQ(counts[talking].devices, 1u);
  EXPECT_EQ(counts[talking].topic_roots, std::vector<std::string>{"realsense/D455_1"});
  EXPECT_EQ(counts[talking].silent, 1u);
  EXPECT_FALSE(counts[talking].never_announced);
  EXPECT_EQ(counts[silent].writers, 2u);
  EXPECT_EQ(counts[silent].devices, 0u);
  EXPECT_TRUE(counts[silent].never_announced);
}
