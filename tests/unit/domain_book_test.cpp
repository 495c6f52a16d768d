// DomainBook is a DDS domain's bookkeeping: which writers announce which
// devices, caps, reconciliation after a new reader, silent writers, lost
// servers. Driven here with made-up writers and times against a real (plain)
// device table: no Cyclone, no network, no sleeping.
#include "dds/domain_book.hpp"

#include "book_sightings.hpp"

#include <gtest/gtest.h>

#include <string>

using namespace std::chrono_literals;
using rsd::dds::BookOptions;
using rsd::dds::DomainBook;

namespace {

const DomainBook::Clock::time_point t0{};

using book_test::id;
using book_test::info;
using book_test::writer;

rsd::dds::Parsed stopping(const std::string& serial) { return rsd::dds::Stopping{"realsense/D455_" + serial}; }


struct Book : ::testing::Test {
  rsd::SharedTable table;
  BookOptions options = [] {
    BookOptions o;
    o.domain = 7;
    o.max_devices_per_participant = 3;
    o.max_devices_per_domain = 5;
    return o;
  }();
  DomainBook book{table, options};

  std::string shown_server(const std::string& serial) {
    const auto dev = table.find(id(serial));
    return dev ? (*dev)["server"]["participant-name"].get<std::string>() : "(absent)";
  }
  rsd::DomainStatus status() {
    rsd::DomainStatus s;
    book.fill(s);
    return s;
  }
};

}  // namespace

TEST_F(Book, WhatTheDaemonSaysOfACameraIsNeverTakenFromItsMessage) {
  book.writer_matched(1, writer(1, 1), t0);
  auto parsed = info("100");
  std::get<rsd::dds::DeviceInfo>(parsed).fields.update({{"server", "me"},
                                                        {"in-use", {{"clients", 9}, {"streaming", {"Depth"}}}},
                                                        {"ready", false},
                                                        {"ready-stage", "stream 1 of 3"},
                                                        {"unresponsive", true}});
  book.sample(1, std::move(parsed));
  const auto dev = table.find(id("100"));
  ASSERT_TRUE(dev);
  EXPECT_EQ((*dev)["server"]["participant-name"], "server-1");
  for (const char* key : {"in-use", "ready", "ready-stage", "unresponsive"}) EXPECT_FALSE(dev->contains(key)) << key;
}

TEST_F(Book, AnnouncedDeviceCarriesItsServer) {
  book.writer_matched(1, writer(1, 1), t0);
  book.sample(1, info("100"));
  const auto dev = table.find(id("100"));
  ASSERT_TRUE(dev);
  EXPECT_EQ((*dev)["source"], "dds");
  EXPECT_EQ((*dev)["domain"], 7);
  EXPECT_EQ((*dev)["recovery"], false);
  EXPECT_EQ((*dev)["server"]["participant-name"], "server-1");
  EXPECT_EQ((*dev)["server"]["writer-guid"], writer(1, 1).guid);
  EXPECT_EQ((*dev)["server"]["addresses"], nlohmann::json::array({"10.0.0.1"}));
  const auto generation = table.generation();
  book.sample(1, info("100"));  // a re-announcement is not news
  EXPECT_EQ(table.generation(), generation);
  EXPECT_EQ(status().accepted, 2u);
}

TEST_F(Book, StoppingRemovesFromItsWriterOrFromAnyone) {
  book.writer_matched(1, writer(1, 1), t0);
  book.sample(1, info("100"));
  book.sample(1, info("101"));
  book.sample(1, stopping("100"));
  EXPECT_FALSE(table.find(id("100")));
  book.sample(99, stopping("101"));  // a writer the book does not know
  EXPECT_FALSE(table.find(id("101")));
  EXPECT_EQ(status().stopping, 2u);
  EXPECT_EQ(status().devices, 0u);
}

TEST_F(Book, DeviceStaysWhileAnyWriterAnnouncesIt) {
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(2, 1), t0);
  book.sample(1, info("100"));
  book.sample(2, info("100"));
  EXPECT_EQ(shown_server("100"), "server-2");  // the latest announcer
  book.writer_left(2, {1}, t0 + 1s);
  EXPECT_EQ(shown_server("100"), "server-1");
  book.writer_left(1, {}, t0 + 2s);
  EXPECT_EQ(shown_server("100"), "(absent)");
}

TEST_F(Book, StoppingFromOneOfTwoServersKeepsTheDevice) {
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(2, 1), t0);
  book.sample(1, info("100"));
  book.sample(2, info("100"));
  book.sample(2, stopping("100"));
  EXPECT_EQ(shown_server("100"), "server-1");
}

TEST_F(Book, CapsPerParticipantAndPerDomain) {
  book.writer_matched(1, writer(1, 1), t0);
  for (int n = 0; n < 10; ++n) book.sample(1, info(std::to_string(200 + n)));
  EXPECT_EQ(status().devices, 3u);  // max_devices_per_participant
  EXPECT_EQ(status().rejected.at("participant-device-limit"), 7u);
  book.sample(1, info("200"));  // a device already known is never refused
  EXPECT_EQ(status().rejected.at("participant-device-limit"), 7u);

  book.writer_matched(2, writer(2, 1), t0);
  for (int n = 0; n < 10; ++n) book.sample(2, info(std::to_string(300 + n)));
  EXPECT_EQ(status().devices, 5u);  // max_devices_per_domain
  EXPECT_EQ(status().rejected.at("domain-device-limit"), 8u);

  // A participant's devices leaving frees its share of the cap.
  book.writer_left(1, {2}, t0 + 1s);
  book.sample(2, info("400"));
  EXPECT_TRUE(table.find(id("400")));
}

// A reload lowers a cap: the devices found last go, as `refused`; a device another
// server still announces stays.
TEST_F(Book, ALoweredCapRefusesTheDevicesFoundLast) {
  using rsd::model::RemovalReason;
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(2, 2), t0);
  for (const char* serial : {"200", "201", "202"}) book.sample(1, info(serial));
  book.sample(2, info("300"));
  book.sample(2, info("200"));  // a second server of 200

  const auto refused = book.set_device_caps(1, 5);
  EXPECT_EQ(refused, (std::vector<std::string>{id("300"), id("202"), id("201")}));
  for (const char* serial : {"201", "202", "300"}) EXPECT_EQ(table.find_gone(id(serial))->reason, RemovalReason::refused);
  EXPECT_TRUE(table.find(id("200")));
  EXPECT_EQ(status().devices, 1u);

  // The lowered cap holds for what comes next, and raising it lets devices in again.
  book.writer_matched(3, writer(3, 3), t0);
  book.sample(3, info("400"));
  EXPECT_TRUE(table.find(id("400")));
  EXPECT_EQ(book.set_device_caps(1, 1), std::vector<std::string>{id("400")});
  book.sample(3, info("400"));
  EXPECT_EQ(status().rejected.at("domain-device-limit"), 1u);
  EXPECT_TRUE(book.set_device_caps(3, 5).empty());
  book.sample(3, info("400"));
  EXPECT_TRUE(table.find(id("400")));
}

TEST_F(Book, MalformedInputIsCountedByReason) {
  book.writer_matched(1, writer(1, 1), t0);
  book.sample(1, rsd::dds::Rejected{"not-json", "x"});
  book.sample(1, rsd::dds::Rejected{"not-json", "y"});
  EXPECT_EQ(status().rejected.at("not-json"), 2u);
  EXPECT_EQ(status().devices, 0u);
}

TEST_F(Book, ANewReaderKeepsDevicesWhoseWritersComeBack) {
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(2, 1), t0);
  book.sample(1, info("100"));
  book.sample(2, info("200"));
  book.reader_made(t0 + 10s);  // handles are per reader: every writer matches anew
  book.writer_matched(11, writer(1, 1), t0 + 10s);
  book.writer_left(99, {11}, t0 + 11s);  // some writer leaving meanwhile drops nothing else
  EXPECT_TRUE(table.find(id("200")));
  EXPECT_EQ(book.tick(t0 + 11500ms, {11}).refresh, false);
  EXPECT_TRUE(table.find(id("200")));  // before the deadline
  book.tick(t0 + 12s, {11});           // reconcile_grace (2 s) after the reader
  EXPECT_TRUE(table.find(id("100")));
  EXPECT_FALSE(table.find(id("200")));
}

TEST_F(Book, AOneDeviceServerWhoseBroadcastWasLostIsAskedAgain) {
  // pyrealdds 2.59.1 with one device often matches exactly one writer: its
  // broadcast lost, that single silent writer is enough to make the reader anew.
  book.writer_matched(1, writer(1, 1), t0);
  EXPECT_FALSE(book.tick(t0 + 2s, {1}).make_reader_anew);  // within the grace
  EXPECT_TRUE(book.tick(t0 + 3s, {1}).make_reader_anew);
  book.reader_made(t0 + 3s);
  book.writer_matched(1, writer(1, 1), t0 + 3s);
  book.sample(1, info("100"));  // the broadcast to the new reader arrives
  EXPECT_TRUE(table.find(id("100")));
  for (int s = 4; s < 60; ++s) EXPECT_FALSE(book.tick(t0 + std::chrono::seconds(s), {1}).make_reader_anew);
}

TEST_F(Book, AServerWithDevicesAndOneIdleWriterIsLeftAlone) {
  // One device and the writer that never writes (k + 1 writers, pyrealdds in some
  // runs): the common case costs no new reader.
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(1, 2), t0);
  book.sample(1, info("100"));
  int anew = 0;
  for (int s = 1; s < 60; ++s) anew += book.tick(t0 + std::chrono::seconds(s), {1, 2}).make_reader_anew;
  EXPECT_EQ(anew, 0);
  EXPECT_TRUE(table.find(id("100")));
}

TEST_F(Book, AnIdleWriterBesideALostBroadcastCostsOneNewReader) {
  // k + 1 writers and the one device's broadcast lost: two silent writers, no device.
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(1, 2), t0);
  EXPECT_TRUE(book.tick(t0 + 3s, {1, 2}).make_reader_anew);
  book.reader_made(t0 + 3s);
  book.writer_matched(1, writer(1, 1), t0 + 3s);
  book.writer_matched(2, writer(1, 2), t0 + 3s);
  book.sample(1, info("100"));  // the device writer answers the new reader; the idle one never does
  int anew = 0;
  for (int s = 4; s < 60; ++s) anew += book.tick(t0 + std::chrono::seconds(s), {1, 2}).make_reader_anew;
  EXPECT_EQ(anew, 0);
  EXPECT_TRUE(table.find(id("100")));
  // Another server's lost broadcast is judged on its own.
  book.writer_matched(3, writer(2, 1), t0 + 60s);
  EXPECT_TRUE(book.tick(t0 + 63s, {1, 2, 3}).make_reader_anew);
}

TEST_F(Book, AParticipantGoneTakesItsDevicesAtOnceEvenWhileReconciling) {
  // A reader made anew just before a server was SIGKILLed never sees that server's
  // writers leave (they never matched it): its participant's end removes them.
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(2, 1), t0);
  book.writer_matched(3, writer(3, 1), t0);
  book.sample(1, info("100"));
  book.sample(2, info("200"));
  book.sample(3, info("100"));  // a second server of the same camera
  book.reader_made(t0 + 1s);
  book.writer_matched(12, writer(2, 1), t0 + 1s);
  book.writer_matched(13, writer(3, 1), t0 + 1s);  // server 1's writer does not come back
  book.participant_gone(writer(2, 1).participant_guid, t0 + 1500ms);
  EXPECT_FALSE(table.find(id("200")));              // before the reconcile grace ends
  book.participant_gone(writer(3, 1).participant_guid, t0 + 1600ms);
  ASSERT_TRUE(table.find(id("100")));               // server 1 still announces it
  EXPECT_EQ(shown_server("100"), "server-1");
  book.participant_gone(writer(1, 1).participant_guid, t0 + 1700ms);
  EXPECT_FALSE(table.find(id("100")));
  EXPECT_EQ(status().lost_servers, 0u);  // judged lost only after the check delay
  book.tick(t0 + 2500ms, {});
  EXPECT_EQ(status().lost_servers, 3u);
}

TEST_F(Book, SilentWritersMakeTheReaderAnewAFewTimesAtMost) {
  // A peer that keeps adding writers that never write cannot loop us.
  int retries = 0;
  for (int round = 0; round < 10; ++round) {
    const auto now = t0 + std::chrono::seconds(10 * round);
    book.writer_matched(static_cast<DomainBook::Handle>(100 + round), writer(1, 100 + round), now);
    if (book.tick(now + 3s, {}).make_reader_anew) {
      ++retries;
      book.reader_made(now + 3s);
    }
  }
  EXPECT_EQ(retries, 3);  // silent_retries
}

TEST_F(Book, WhatIsLearntOfAServerGoesWithIt) {
  // An idle writer's server leaves and a new one (another GUID) is judged anew;
  // nothing is kept for servers gone.
  book.writer_matched(1, writer(1, 1), t0);
  EXPECT_TRUE(book.tick(t0 + 3s, {1}).make_reader_anew);
  book.reader_made(t0 + 3s);
  book.writer_matched(1, writer(1, 1), t0 + 3s);
  EXPECT_FALSE(book.tick(t0 + 6s, {1}).make_reader_anew);  // idle now
  book.writer_left(1, {}, t0 + 7s);
  book.writer_matched(2, writer(1, 1), t0 + 8s);  // the same GUID back (a restarted peer)
  EXPECT_TRUE(book.tick(t0 + 11s, {2}).make_reader_anew);
}

TEST_F(Book, ALostServerAsksForARefreshAndIsFoundAgain) {
  book.reader_made(t0 - 10s);
  book.participant_alive(writer(1, 1).participant_guid, t0);
  book.writer_matched(1, writer(1, 1), t0);
  book.sample(1, info("100"));
  book.participant_gone(writer(1, 1).participant_guid, t0);  // its lease expired (a cut)
  book.writer_left(1, {}, t0);
  EXPECT_FALSE(table.find(id("100")));
  EXPECT_FALSE(book.tick(t0 + 500ms, {}).refresh);
  EXPECT_EQ(status().lost_servers, 1u);
  EXPECT_FALSE(book.tick(t0 + 1900ms, {}).refresh);
  book.participant_alive(writer(1, 1).participant_guid, t0 + 2s);  // heard again, its writers not
  EXPECT_TRUE(book.tick(t0 + 2s, {}).refresh);  // at once: that participant never hears them
  book.participant_made();
  book.reader_made(t0 + 3s);
  book.writer_matched(1, writer(1, 1), t0 + 3s);
  book.sample(1, info("100"));
  EXPECT_EQ(status().lost_servers, 0u);
  EXPECT_TRUE(table.find(id("100")));
}

TEST_F(Book, AServerDroppingOneDeviceIsNotLost) {
  book.participant_alive(writer(1, 1).participant_guid, t0);
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(1, 2), t0);
  book.sample(1, info("100"));
  book.sample(2, info("101"));
  book.writer_left(1, {2}, t0);  // the server deleted one device's writer
  EXPECT_FALSE(table.find(id("100")));
  for (auto t = 0ms; t < 60s; t += 250ms) EXPECT_FALSE(book.tick(t0 + t, {2}).refresh);
  EXPECT_EQ(status().lost_servers, 0u);
}

TEST_F(Book, ARemovalLineNamesTheServerNotOnlyGuids) {
  book.writer_matched(1, writer(1, 1), t0);
  book.sample(1, info("100"));
  ::testing::internal::CaptureStderr();
  book.writer_left(1, {}, t0 + 1s);
  const std::string log = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(log.find("removed (writer-gone): its writer"), std::string::npos) << log;
  EXPECT_NE(log.find("(server 'server-1' at 10.0.0.1)"), std::string::npos) << log;
  // The table keeps the same words as the camera's gone entry.
  const auto gone = table.find_gone(id("100"));
  ASSERT_TRUE(gone);
  EXPECT_EQ(gone->reason, rsd::model::RemovalReason::writer_gone);
  EXPECT_NE(gone->detail.find("server 'server-1'"), std::string::npos) << gone->detail;
}

TEST_F(Book, ADeviceNotBackAfterANetworkChangeLeftWithTheInterface) {
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(2, 1), t0);
  book.sample(1, info("100"));
  book.sample(2, info("101"));
  book.network_changed();
  book.participant_made();
  book.reader_made(t0 + 1s);
  book.writer_matched(12, writer(2, 1), t0 + 1100ms);  // only server 2 is heard on the new network
  book.tick(t0 + 3500ms, {12});                       // past the reconcile grace
  ASSERT_TRUE(table.find_gone(id("100")));
  EXPECT_EQ(table.find_gone(id("100"))->reason, rsd::model::RemovalReason::interface_gone);
  EXPECT_TRUE(table.find(id("101")));
  // A later reconciliation, not after a network change, says writer-gone again.
  book.reader_made(t0 + 10s);
  book.tick(t0 + 13s, {});
  EXPECT_EQ(table.find_gone(id("101"))->reason, rsd::model::RemovalReason::writer_gone);
}

TEST_F(Book, EachWayOfLeavingHasItsReason) {
  using rsd::model::RemovalReason;
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(2, 1), t0);
  book.writer_matched(3, writer(3, 2), t0);
  book.sample(1, info("100"));
  book.sample(2, info("101"));
  book.sample(3, info("102"));
  book.sample(1, stopping("100"));
  EXPECT_EQ(table.find_gone(id("100"))->reason, RemovalReason::stopping);
  book.writer_gone(2, t0 + 1s);
  EXPECT_EQ(table.find_gone(id("101"))->reason, RemovalReason::writer_gone);
  book.participant_gone(writer(3, 2).participant_guid, t0 + 2s);
  EXPECT_EQ(table.find_gone(id("102"))->reason, RemovalReason::lease_expired);
}

// The main loop sleeps until the book's next deadline: a book driven only at
// its deadlines does what one ticked every 100 ms does.
TEST_F(Book, ASilentWriterIsJudgedAtTheDeadlineTheBookGives) {
  EXPECT_EQ(book.next_deadline(t0), std::nullopt);  // nothing to time: the loop may sleep
  book.writer_matched(1, writer(1, 1), t0);
  const auto due = book.next_deadline(t0);
  ASSERT_EQ(due, t0 + options.silent_grace);
  EXPECT_FALSE(book.tick(*due - 1ms, {1}).make_reader_anew);
  EXPECT_TRUE(book.tick(*due, {1}).make_reader_anew);
  book.reader_made(*due);
  book.writer_matched(1, writer(1, 1), *due);
  EXPECT_EQ(book.next_deadline(*due), *due + options.silent_grace);  // timed again for the new reader
  book.sample(1, info("100"));
  EXPECT_EQ(book.next_deadline(*due), std::nullopt);  // it spoke: nothing left to time
  EXPECT_TRUE(table.find(id("100")));
  // A new reader while devices are listed: its reconciliation is the deadline.
  book.reader_made(*due + 1s);
  EXPECT_EQ(book.next_deadline(*due + 1s), *due + 1s + options.reconcile_grace);
}

TEST_F(Book, ALostServerHeardAgainWaitsForNoDeadline) {
  book.reader_made(t0 - 10s);
  book.participant_alive(writer(1, 1).participant_guid, t0);
  book.writer_matched(1, writer(1, 1), t0);
  book.sample(1, info("100"));
  EXPECT_EQ(book.next_deadline(t0), std::nullopt);
  book.participant_gone(writer(1, 1).participant_guid, t0);  // its lease expired (a cut)
  book.writer_left(1, {}, t0);
  auto at = book.next_deadline(t0);  // the verdict on the suspect
  ASSERT_TRUE(at);
  EXPECT_FALSE(book.tick(*at, {}).refresh);
  EXPECT_EQ(status().lost_servers, 1u);
  // Nothing is due until it is heard again but the blind refresh 30 s on...
  at = book.next_deadline(t0 + 1s);
  ASSERT_TRUE(at);
  EXPECT_GE(*at, t0 + 30s);
  // ...and the hearing is an event (the participant listener wakes the loop):
  // the turn it wakes refreshes, with no deadline to wait for.
  book.participant_alive(writer(1, 1).participant_guid, t0 + 2s);  // heard again, its writers not
  EXPECT_TRUE(book.tick(t0 + 2s, {}).refresh);
}

TEST_F(Book, AClientLeavingIsOneChangeHeldUntilItsEndpointsAreGone) {
  using rsd::model::InUse;
  const std::string root = "realsense/D455_100";
  book.writer_matched(1, writer(1, 1), t0);
  book.sample(1, info("100"));
  const auto in_use = [&]() { return (*table.find(id("100"))).value("in-use", nlohmann::json()); };
  // Coming, and opening a stream: written at once.
  auto generation = table.generation();
  EXPECT_FALSE(book.set_in_use(root, InUse{1, {}}, t0));
  EXPECT_FALSE(book.set_in_use(root, InUse{1, {}}, t0));  // its device's second endpoint: no change
  EXPECT_FALSE(book.set_in_use(root, InUse{1, {"Depth"}}, t0));
  EXPECT_EQ(table.generation(), generation + 2);
  EXPECT_EQ(in_use(), (nlohmann::json{{"clients", 1}, {"streaming", {"Depth"}}}));
  // Leaving: its stream reader goes, then its device's endpoints; held from the
  // first loss, written once, as it is at the end of the hold.
  generation = table.generation();
  EXPECT_TRUE(book.set_in_use(root, InUse{1, {}}, t0 + 1s));
  EXPECT_EQ(book.next_deadline(t0 + 1s), t0 + 1s + options.in_use_hold);
  EXPECT_FALSE(book.set_in_use(root, InUse{0, {}}, t0 + 1s + 20ms));  // the hold is not moved on
  EXPECT_EQ(book.flush_in_use(t0 + 1s + options.in_use_hold - 1ms), t0 + 1s + options.in_use_hold);
  EXPECT_EQ(table.generation(), generation);
  EXPECT_FALSE(book.flush_in_use(t0 + 1s + options.in_use_hold));
  EXPECT_EQ(table.generation(), generation + 1);
  EXPECT_TRUE(in_use().is_null());
  // A client coming back within the hold of a leaving one: written at once, one change.
  EXPECT_FALSE(book.set_in_use(root, InUse{1, {}}, t0 + 3s));
  generation = table.generation();
  EXPECT_TRUE(book.set_in_use(root, InUse{0, {}}, t0 + 4s));
  EXPECT_FALSE(book.set_in_use(root, InUse{1, {}}, t0 + 4s + 10ms));
  book.flush_in_use(t0 + 5s);
  EXPECT_EQ(table.generation(), generation);  // nothing changed in the end
  // With no hold, a loss is written at once.
  BookOptions none = options;
  none.in_use_hold = 0ms;
  rsd::SharedTable other;
  DomainBook unheld{other, none};
  unheld.writer_matched(1, writer(1, 1), t0);
  unheld.sample(1, info("100"));
  unheld.set_in_use(root, InUse{1, {}}, t0);
  EXPECT_FALSE(unheld.set_in_use(root, InUse{0, {}}, t0));
  EXPECT_FALSE((*other.find(id("100"))).contains("in-use"));
}

TEST_F(Book, AKeptDevicesServerSilentForANewReaderIsAskedAgainSooner) {
  // After a refresh on a lossy link: the device is kept, its server's writers match
  // the new reader, and its broadcast is lost. Its idle writer is known already,
  // so one silent writer is all there is; it is asked again after the shorter grace.
  book.writer_matched(1, writer(1, 1), t0);
  book.writer_matched(2, writer(1, 2), t0);
  book.sample(1, info("100"));
  EXPECT_FALSE(book.tick(t0 + 3s, {1, 2}).make_reader_anew);  // writer 2 idle? not yet judged
  book.participant_made();
  book.reader_made(t0 + 10s);
  book.writer_matched(1, writer(1, 1), t0 + 10s);
  book.writer_matched(2, writer(1, 2), t0 + 10s);
  EXPECT_EQ(book.next_deadline(t0 + 10s), t0 + 10s + options.awaited_silent_grace);
  EXPECT_FALSE(book.tick(t0 + 10s + options.awaited_silent_grace - 1ms, {1, 2}).make_reader_anew);
  EXPECT_TRUE(book.tick(t0 + 10s + options.awaited_silent_grace, {1, 2}).make_reader_anew);
  // Lost again for the next reader: a writer that announced a device is not idle.
  book.reader_made(t0 + 12s);
  book.writer_matched(1, writer(1, 1), t0 + 12s);
  book.writer_matched(2, writer(1, 2), t0 + 12s);
  EXPECT_TRUE(book.tick(t0 + 13s, {1, 2}).make_reader_anew);
  book.reader_made(t0 + 14s);
  book.writer_matched(1, writer(1, 1), t0 + 14s);
  book.writer_matched(2, writer(1, 2), t0 + 14s);
  book.sample(1, info("100"));  // heard: nothing more to ask
  for (int s = 15; s < 60; ++s) EXPECT_FALSE(book.tick(t0 + std::chrono::seconds(s), {1, 2}).make_reader_anew);
  EXPECT_TRUE(table.find(id("100")));
}
