// EndpointBook and ParticipantBook::clients: who uses a camera, from made-up
// endpoints as DCPSPublication/DCPSSubscription give them (the topic names are
// the ones a live pyrealdds server and client use), and the bounds a flood of
// endpoints or of long topic names stays within (seeded random runs).
#include "dds/endpoint_book.hpp"
#include "dds/participant_book.hpp"

#include <gtest/gtest.h>

#include <random>
#include <string>

using rsd::dds::EndpointBook;
using rsd::dds::EndpointLimits;
using rsd::dds::EndpointRefusal;
using rsd::dds::ParticipantBook;
using rsd::dds::ParticipantSighting;
namespace topics = rsd::dds::realdds_topics;

namespace {

const std::string kRoot = "realsense/D555_555777";
const std::string kServer = "010f78fd.d02bf8d2.00000000.000001c1";
const std::string kApp = "010f78fd.bd2b6229.00000000.000001c1";
const std::string kOther = "0110abcd.00000001.00000002.000001c1";

std::string ep(const std::string& participant, int n) {
  return participant.substr(0, 27) + std::to_string(100000 + n);
}

// What a realdds server with Depth, Infrared 1 and Color has on the wire.
void server(ParticipantBook& book, const std::string& root = kRoot, const std::string& guid = kServer) {
  book.endpoint_alive(guid, ep(guid, 1), root + "/notification", false, "T0");
  book.endpoint_alive(guid, ep(guid, 2), "rt/" + root + "_Depth", false, "T0");
  book.endpoint_alive(guid, ep(guid, 3), "rt/" + root + "_Infrared 1", false, "T0");
  book.endpoint_alive(guid, ep(guid, 4), "rt/" + root + "_Color", false, "T0");
  book.endpoint_alive(guid, ep(guid, 5), root + "/control", true, "T0");
  book.endpoint_alive(guid, ep(guid, 6), "realsense/device-info", false, "T0");
}

// pyrealdds' dds.device(p, info): a control writer and a notification reader.
void device_of(ParticipantBook& book, const std::string& guid, const std::string& root, const std::string& now) {
  book.endpoint_alive(guid, ep(guid, 1), root + "/control", false, now);
  book.endpoint_alive(guid, ep(guid, 2), root + "/notification", true, now);
}

}  // namespace

TEST(RealddsTopics, RootsOfEachKindOfTopic) {
  EXPECT_EQ(topics::roots_of("realsense/D555_1/notification"), std::vector<std::string>{"realsense/D555_1"});
  EXPECT_EQ(topics::roots_of("realsense/D555_1/control"), std::vector<std::string>{"realsense/D555_1"});
  EXPECT_EQ(topics::roots_of("realsense/D555_1/metadata"), std::vector<std::string>{"realsense/D555_1"});
  // A stream topic names its root only up to one of its '_': every candidate.
  EXPECT_EQ(topics::roots_of("rt/realsense/D555_1_Infrared 1"),
            (std::vector<std::string>{"realsense/D555", "realsense/D555_1"}));
  EXPECT_TRUE(topics::roots_of("realsense/device-info").empty());
  EXPECT_TRUE(topics::roots_of("rt/_").empty());
  EXPECT_TRUE(topics::roots_of("/notification").empty());
}

TEST(ParticipantBookClients, ADeviceOnlyIsAClientWithNoStreams) {
  ParticipantBook book;
  server(book);
  ParticipantSighting app;
  app.guid = kApp;
  app.name = "my-robot-app";
  app.addresses = {"192.0.2.7"};
  book.alive(app, "T1");
  device_of(book, kApp, kRoot, "T1");
  const auto c = book.clients(kRoot, {kServer});
  ASSERT_EQ(c.clients.size(), 1u);
  EXPECT_EQ(c.clients[0].guid, kApp);
  EXPECT_EQ(c.clients[0].name, "my-robot-app");
  EXPECT_EQ(c.clients[0].addresses, std::vector<std::string>{"192.0.2.7"});
  EXPECT_EQ(c.clients[0].vendor, rsd::model::Vendor::fast_dds);
  EXPECT_EQ(c.clients[0].since, "T1");
  EXPECT_TRUE(c.clients[0].streams.empty());
  EXPECT_TRUE(c.streams.empty());
  EXPECT_EQ(rsd::model::summary_of(c), (rsd::model::InUse{1, {}}));
  // Its server, even unnamed, is no client of its own topics: it reads control and writes the rest.
  EXPECT_EQ(book.clients(kRoot, {}).clients.size(), 1u);
}

TEST(ParticipantBookClients, ASecondServerOfTheSameRootIsNoClient) {
  ParticipantBook book;
  server(book);
  device_of(book, kApp, kRoot, "T1");
  // A new server process for the same camera makes its endpoints before its
  // device-info is heard, so only the first server is named as one.
  server(book, kRoot, kOther);
  const auto c = book.clients(kRoot, {kServer});
  ASSERT_EQ(c.clients.size(), 1u);
  EXPECT_EQ(c.clients[0].guid, kApp);
  EXPECT_TRUE(c.streams.empty());  // its stream writers are nobody streaming
  EXPECT_EQ(rsd::model::summary_of(c), (rsd::model::InUse{1, {}}));
  // The app opens Depth: one reader, the servers' two writers do not count.
  book.endpoint_alive(kApp, ep(kApp, 3), "rt/" + kRoot + "_Depth", true, "T2");
  EXPECT_EQ(book.clients(kRoot, {kServer}).streams, (std::map<std::string, std::size_t>{{"Depth", 1}}));
  // The app gone, neither server is left as a client.
  book.gone(kApp, "T3");
  EXPECT_TRUE(book.clients(kRoot, {kServer}).clients.empty());
  EXPECT_TRUE(book.clients(kRoot, {}).clients.empty());
}

TEST(ParticipantBookClients, OnlyAClientsDirectionOnEachTopicCounts) {
  ParticipantBook book;
  // Each lone endpoint a client has makes it one; the opposite ones do not.
  book.endpoint_alive(kApp, ep(kApp, 1), kRoot + "/control", false, "T1");
  book.endpoint_alive(kOther, ep(kOther, 1), kRoot + "/control", true, "T1");
  EXPECT_EQ(book.clients(kRoot, {}).clients.size(), 1u);
  book.endpoint_gone(kApp, ep(kApp, 1));
  book.endpoint_alive(kApp, ep(kApp, 2), kRoot + "/metadata", true, "T1");
  book.endpoint_alive(kOther, ep(kOther, 2), kRoot + "/metadata", false, "T1");
  book.endpoint_alive(kOther, ep(kOther, 3), kRoot + "/notification", false, "T1");
  book.endpoint_alive(kOther, ep(kOther, 4), "rt/" + kRoot + "_Color", false, "T1");
  const auto c = book.clients(kRoot, {});
  ASSERT_EQ(c.clients.size(), 1u);
  EXPECT_EQ(c.clients[0].guid, kApp);
  EXPECT_TRUE(c.streams.empty());
}

TEST(ParticipantBookClients, AStreamReaderStreamsAndGoesWithItsParticipant) {
  ParticipantBook book;
  server(book);
  device_of(book, kApp, kRoot, "T1");
  book.endpoint_alive(kApp, ep(kApp, 3), "rt/" + kRoot + "_Depth", true, "T2");
  device_of(book, kOther, kRoot, "T3");
  book.endpoint_alive(kOther, ep(kOther, 3), "rt/" + kRoot + "_Depth", true, "T3");
  book.endpoint_alive(kOther, ep(kOther, 4), "rt/" + kRoot + "_Infrared 1", true, "T3");
  auto c = book.clients(kRoot, {kServer});
  ASSERT_EQ(c.clients.size(), 2u);
  EXPECT_EQ(c.clients[0].guid, kApp);  // by GUID
  EXPECT_EQ(c.clients[0].streams, std::vector<std::string>{"Depth"});
  EXPECT_EQ(c.clients[0].since, "T1");  // its first endpoint on the camera
  EXPECT_EQ(c.clients[1].streams, (std::vector<std::string>{"Depth", "Infrared 1"}));
  EXPECT_EQ(c.streams, (std::map<std::string, std::size_t>{{"Depth", 2}, {"Infrared 1", 1}}));
  EXPECT_EQ(rsd::model::summary_of(c), (rsd::model::InUse{2, {"Depth", "Infrared 1"}}));

  // The stream closed: its reader goes, the client stays.
  EXPECT_EQ(book.endpoint_gone(kOther, ep(kOther, 4)), "rt/" + kRoot + "_Infrared 1");
  EXPECT_EQ(rsd::model::summary_of(book.clients(kRoot, {kServer})), (rsd::model::InUse{2, {"Depth"}}));
  // Its participant gone (lease or goodbye): every endpoint with it.
  const auto touched = book.gone(kOther, "T4");
  EXPECT_EQ(touched.size(), 3u);
  EXPECT_EQ(rsd::model::summary_of(book.clients(kRoot, {kServer})), (rsd::model::InUse{1, {"Depth"}}));
  EXPECT_EQ(book.endpoints().count(kOther), 0u);
}

TEST(ParticipantBookClients, AClientOfOneCameraIsNeverCountedForAnother) {
  ParticipantBook book;
  const std::string other_root = "realsense/D555_5557770";  // the first one's root is its prefix
  server(book);
  server(book, other_root, kOther);
  device_of(book, kApp, other_root, "T1");
  book.endpoint_alive(kApp, ep(kApp, 3), "rt/" + other_root + "_Depth", true, "T1");
  EXPECT_TRUE(book.clients(kRoot, {kServer}).clients.empty());
  EXPECT_EQ(book.clients(other_root, {kOther}).clients.size(), 1u);
  EXPECT_EQ(book.clients(other_root, {kOther}).streams.at("Depth"), 1u);
}

TEST(EndpointBook, RefusesBeyondItsLimitsAndCountsWhy) {
  EndpointLimits limits;
  limits.per_participant = 3;
  limits.per_domain = 5;
  limits.topic_length = 16;
  limits.topics = 2;
  EndpointBook book(limits);
  EXPECT_EQ(book.alive("p1", "e1", "a", false, "T"), EndpointRefusal::none);
  EXPECT_EQ(book.alive("p1", "e1", "a", false, "T"), EndpointRefusal::none);  // the same again: nothing new
  EXPECT_EQ(book.alive("p1", "e2", std::string(17, 'x'), false, "T"), EndpointRefusal::topic_too_long);
  EXPECT_EQ(book.alive("p1", "e3", "b", true, "T"), EndpointRefusal::none);
  EXPECT_EQ(book.alive("p1", "e4", "a", true, "T"), EndpointRefusal::participant_limit);
  EXPECT_EQ(book.alive("p2", "e5", "c", true, "T"), EndpointRefusal::topic_limit);  // kept, without its topic
  EXPECT_EQ(book.alive("p2", "e6", "a", true, "T"), EndpointRefusal::none);
  EXPECT_EQ(book.alive("p3", "e7", "a", true, "T"), EndpointRefusal::domain_limit);
  EXPECT_EQ(book.total(), 5u);
  EXPECT_EQ(book.count("p1"), 3u);
  EXPECT_EQ(book.topics(), 2u);
  EXPECT_EQ(book.refused(EndpointRefusal::topic_too_long), 1u);
  EXPECT_EQ(book.refused(EndpointRefusal::participant_limit), 1u);
  EXPECT_EQ(book.refused(EndpointRefusal::topic_limit), 1u);
  EXPECT_EQ(book.refused(EndpointRefusal::domain_limit), 1u);
  EXPECT_STREQ(rsd::dds::to_string(EndpointRefusal::domain_limit), "domain-endpoint-limit");
  EXPECT_EQ(book.gone("p1", "e2"), "");  // kept without its topic
  EXPECT_EQ(book.gone("p1", "e3"), "b");
  EXPECT_EQ(book.topics(), 1u);
  book.participant_gone("p2");
  book.participant_gone("p1");
  EXPECT_EQ(book.total(), 0u);
  EXPECT_EQ(book.topics(), 0u);
}

// A flood: endpoints of many participants, long and ever new topic names, camera
// topics among them, coming and going at random. The book never holds more than
// its limits, its counts agree with what is alive, and once every participant is
// gone nothing is left.
TEST(EndpointBook, AFloodStaysWithinItsBounds) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    EndpointLimits limits;
    limits.per_participant = 1 + rng() % 40;
    limits.per_domain = 50 + rng() % 500;
    limits.topic_length = 8 + rng() % 300;
    limits.topics = 1 + rng() % 200;
    ParticipantBook book(4096, 256, limits);
    std::map<std::string, std::set<std::string>> alive;  // what the book accepted
    for (int step = 0; step < 5000; ++step) {
      const std::string participant = "010f0000.0000" + std::to_string(rng() % 60) + ".00000000.000001c1";
      const std::string endpoint = participant.substr(0, 27) + std::to_string(rng() % 100);
      const auto what = rng() % 10;
      if (what < 6) {
        std::string topic;
        switch (rng() % 4) {
          case 0: topic = kRoot + "/control"; break;
          case 1: topic = "rt/" + kRoot + "_" + std::string(1 + rng() % 400, 'S'); break;
          case 2: topic = std::string(rng() % 2000, 'x'); break;
          default: topic = "t" + std::to_string(rng()); break;
        }
        const auto r = book.endpoint_alive(participant, endpoint, topic, rng() % 2, "T");
        if (r != EndpointRefusal::participant_limit && r != EndpointRefusal::domain_limit)
          alive[participant].insert(endpoint);  // kept, with its topic or without
      } else if (what < 9) {
        book.endpoint_gone(participant, endpoint);
        alive[participant].erase(endpoint);
      } else {
        book.gone(participant, "T");
        alive.erase(participant);
      }
      const auto& e = book.endpoints();
      ASSERT_LE(e.total(), limits.per_domain) << "seed " << seed;
      ASSERT_LE(e.topics(), limits.topics) << "seed " << seed;
      ASSERT_LE(e.count(participant), limits.per_participant) << "seed " << seed;
      ASSERT_EQ(e.count(participant), alive[participant].size()) << "seed " << seed << " step " << step;
      const auto c = book.clients(kRoot, {});
      ASSERT_LE(c.clients.size(), 60u);
      for (const auto& [stream, readers] : c.streams) ASSERT_LE(stream.size() + 3 + kRoot.size() + 1, limits.topic_length);
    }
    std::size_t sum = 0;
    for (const auto& [p, set] : alive) sum += set.size();
    EXPECT_EQ(book.endpoints().total(), sum);
    for (int p = 0; p < 60; ++p) book.gone("010f0000.0000" + std::to_string(p) + ".00000000.000001c1", "T");
    EXPECT_EQ(book.endpoints().total(), 0u);
    EXPECT_EQ(book.endpoints().topics(), 0u);
  }
}

TEST(EndpointBook, RandomClientsOfTwoCamerasAreNeverCountedForTheOther) {
  const std::string other_root = "realsense/D555_111222";  // shares kRoot's prefix up to its '_'
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    ParticipantBook book;
    std::map<std::string, std::map<std::string, std::string>> used;  // participant -> endpoint -> root
    for (int step = 0; step < 3000; ++step) {
      const std::string participant = "010f0000.0000" + std::to_string(rng() % 30) + ".00000000.000001c1";
      const std::string endpoint = participant.substr(0, 27) + std::to_string(rng() % 20);
      const std::string& root = rng() % 2 ? kRoot : other_root;
      if (rng() % 3) {
        const bool reader = rng() % 2;
        // A client's direction: it writes control and reads the rest.
        const std::string topic = reader ? (rng() % 2 ? root + "/notification" : "rt/" + root + "_Depth")
                                         : root + "/control";
        if (book.endpoint_alive(participant, endpoint, topic, reader, "T") == EndpointRefusal::none &&
            !used[participant].count(endpoint))
          used[participant][endpoint] = root;
      } else {
        book.endpoint_gone(participant, endpoint);
        used[participant].erase(endpoint);
      }
      for (const auto* r : {&kRoot, &other_root}) {
        std::set<std::string> want;
        for (const auto& [p, eps] : used)
          for (const auto& [e, of] : eps)
            if (of == *r) want.insert(p);
        std::set<std::string> got;
        for (const auto& c : book.clients(*r, {}).clients) got.insert(c.guid);
        ASSERT_EQ(got, want) << "seed " << seed << " step " << step << " camera " << *r;
      }
    }
    for (int p = 0; p < 30; ++p) book.gone("010f0000.0000" + std::to_string(p) + ".00000000.000001c1", "T");
    EXPECT_TRUE(book.clients(kRoot, {}).clients.empty());
    EXPECT_TRUE(book.clients(other_root, {}).clients.empty());
    EXPECT_EQ(book.endpoints().total(), 0u);
  }
}

TEST(RealddsTopics, AStreamOfALongerKnownRootIsThatCamerasOnly) {
  const auto known = [](std::string_view r) { return r == "realsense/D555_1" || r == "realsense/D555_1_X"; };
  EXPECT_EQ(topics::stream_of("rt/realsense/D555_1_Depth", "realsense/D555_1", known), "Depth");
  EXPECT_EQ(topics::stream_of("rt/realsense/D555_1_Infrared 1", "realsense/D555_1", known), "Infrared 1");
  // rt/<R>_X_Depth, where <R>_X is a camera: X's Depth, not R's stream "X_Depth".
  EXPECT_EQ(topics::stream_of("rt/realsense/D555_1_X_Depth", "realsense/D555_1", known), "");
  EXPECT_EQ(topics::stream_of("rt/realsense/D555_1_X_Depth", "realsense/D555_1_X", known), "Depth");
  // Without the longer camera known, R's stream keeps its '_' verbatim.
  EXPECT_EQ(topics::stream_of("rt/realsense/D555_1_X_Depth", "realsense/D555_1"), "X_Depth");
  EXPECT_EQ(topics::stream_of("rt/realsense/D555_10_Depth", "realsense/D555_1", known), "");
  EXPECT_EQ(topics::stream_of("realsense/D555_1/control", "realsense/D555_1", known), "");
  EXPECT_TRUE(topics::is_camera_topic("realsense/D555_1/control", "realsense/D555_1", known));
  EXPECT_FALSE(topics::is_camera_topic("realsense/D555_1_X/control", "realsense/D555_1", known));
  EXPECT_FALSE(topics::is_camera_topic("rt/realsense/D555_1_X_Depth", "realsense/D555_1", known));
}

TEST(ParticipantBookClients, AStreamOfACameraWhoseRootExtendsAnotherIsCountedForItOnly) {
  ParticipantBook book;
  const std::string longer = kRoot + "_X";  // a camera whose root is kRoot + "_X"
  const auto known = [&](std::string_view r) { return r == kRoot || r == longer; };
  server(book);
  server(book, longer, kOther);
  device_of(book, kApp, longer, "T1");
  book.endpoint_alive(kApp, ep(kApp, 3), "rt/" + longer + "_Depth", true, "T1");
  EXPECT_TRUE(book.clients(kRoot, {kServer}, known).clients.empty());
  EXPECT_TRUE(book.clients(kRoot, {kServer}, known).streams.empty());
  const auto c = book.clients(longer, {kOther}, known);
  ASSERT_EQ(c.clients.size(), 1u);
  EXPECT_EQ(c.clients[0].streams, std::vector<std::string>{"Depth"});
  EXPECT_EQ(c.streams, (std::map<std::string, std::size_t>{{"Depth", 1}}));
  // Not knowing the longer camera, the reader is kRoot's stream "X_Depth", as named.
  EXPECT_EQ(book.clients(kRoot, {kServer}).streams, (std::map<std::string, std::size_t>{{"X_Depth", 1}}));
  // A client of both: each camera counts its own stream.
  const std::string both = "0110abcd.99999999.00000000.000001c1";
  device_of(book, both, kRoot, "T2");
  book.endpoint_alive(both, ep(both, 3), "rt/" + kRoot + "_Depth", true, "T2");
  book.endpoint_alive(both, ep(both, 4), "rt/" + longer + "_Depth", true, "T2");
  EXPECT_EQ(book.clients(kRoot, {kServer}, known).streams, (std::map<std::string, std::size_t>{{"Depth", 1}}));
  EXPECT_EQ(book.clients(longer, {kOther}, known).streams, (std::map<std::string, std::size_t>{{"Depth", 2}}));
}
