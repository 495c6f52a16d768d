// parse_ros_discovery_info and ParticipantBook's ROS 2 node names: samples built
// here byte by byte as rmw writes them (plain CDR, a GID of 24 octets for ROS 2
// Humble, 16 for Iron and later, either byte order), the malformed ones refused,
// random bytes and cut samples never read past their end, and a client named by
// the nodes owning its endpoints on the camera's topics only.
#include "dds/participant_book.hpp"
#include "dds/ros_nodes.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

using rsd::dds::parse_ros_discovery_info;
using rsd::dds::ParticipantBook;
using rsd::dds::RosInfoLimits;
using rsd::dds::RosNode;

namespace {

struct NodeSpec {
  std::string ns, name;
  std::vector<std::string> readers, writers;  // GUIDs as the daemon spells them
};

// Writes one sample as rmw does: the encapsulation header, then plain CDR.
class Sample {
 public:
  Sample(std::size_t gid_size, bool little) : gid_size_(gid_size), little_(little) {
    bytes_ = {0, static_cast<unsigned char>(little ? 1 : 0), 0, 0};
  }
  Sample& u32(std::uint32_t v) {
    while ((bytes_.size() - 4) % 4) bytes_.push_back(0);
    for (int i = 0; i < 4; ++i) bytes_.push_back(static_cast<unsigned char>(v >> (little_ ? 8 * i : 8 * (3 - i))));
    return *this;
  }
  Sample& text(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size() + 1));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
    bytes_.push_back(0);
    return *this;
  }
  Sample& gid(const std::string& guid) {  // "0110a3b1.22c44e8f.7f000001.000001c1"
    std::string hex;
    for (char c : guid)
      if (c != '.') hex += c;
    for (std::size_t i = 0; i < 32; i += 2) bytes_.push_back(static_cast<unsigned char>(std::stoi(hex.substr(i, 2), nullptr, 16)));
    bytes_.resize(bytes_.size() + gid_size_ - 16, 0);  // Humble's zeros
    return *this;
  }
  Sample& info(const std::string& participant, const std::vector<NodeSpec>& nodes) {
    gid(participant).u32(static_cast<std::uint32_t>(nodes.size()));
    for (const auto& n : nodes) {
      text(n.ns).text(n.name);
      for (const auto* list : {&n.readers, &n.writers}) {
        u32(static_cast<std::uint32_t>(list->size()));
        for (const auto& g : *list) gid(g);
      }
    }
    while (bytes_.size() % 4) bytes_.push_back(0);  // rmw pads the payload
    return *this;
  }
  std::vector<unsigned char>& bytes() { return bytes_; }

 private:
  std::size_t gid_size_;
  bool little_;
  std::vector<unsigned char> bytes_;
};

const std::string kRosParticipant = "010fa1b2.c3d4e5f6.01020304.000001c1";
const std::string kDepthReader = "010fa1b2.c3d4e5f6.01020304.00001204";
const std::string kImuWriter = "010fa1b2.c3d4e5f6.01020304.00001303";
const std::string kRoot = "realsense/D555_555777";
const std::string kServer = "010f78fd.d02bf8d2.00000000.000001c1";

const std::vector<NodeSpec> kTwoNodes = {{"/robot", "viewer", {kDepthReader}, {}},
                                         {"/", "imu_filter", {}, {kImuWriter}}};

}  // namespace

TEST(RosDiscoveryInfo, HumbleAndIronSamplesInEitherByteOrder) {
  for (const std::size_t gid_size : {std::size_t{24}, std::size_t{16}}) {
    for (const bool little : {true, false}) {
      SCOPED_TRACE("gid " + std::to_string(gid_size) + (little ? " LE" : " BE"));
      Sample s(gid_size, little);
      const auto info = parse_ros_discovery_info(s.info(kRosParticipant, kTwoNodes).bytes());
      ASSERT_TRUE(info);
      EXPECT_EQ(info->participant, kRosParticipant);
      ASSERT_EQ(info->nodes.size(), 2u);
      EXPECT_EQ(info->nodes[0].name, "/robot/viewer");
      EXPECT_EQ(info->nodes[0].endpoints, std::vector<std::string>{kDepthReader});
      EXPECT_EQ(info->nodes[1].name, "/imu_filter");
      EXPECT_EQ(info->nodes[1].endpoints, std::vector<std::string>{kImuWriter});
    }
  }
}

TEST(RosDiscoveryInfo, AParticipantWithNoNodesIsReadForEitherSize) {
  // The two layouts' shortest samples, which the other size must not take.
  for (const std::size_t gid_size : {std::size_t{24}, std::size_t{16}}) {
    Sample s(gid_size, true);
    const auto info = parse_ros_discovery_info(s.info(kRosParticipant, {}).bytes());
    ASSERT_TRUE(info) << gid_size;
    EXPECT_EQ(info->participant, kRosParticipant);
    EXPECT_TRUE(info->nodes.empty());
  }
}

TEST(RosDiscoveryInfo, MalformedSamplesAreRefused) {
  const auto good = [] { return Sample(16, true).info(kRosParticipant, kTwoNodes).bytes(); };
  EXPECT_FALSE(parse_ros_discovery_info({}));
  auto kind = good();
  kind[1] = 2;  // parameter-list CDR: not this type's
  EXPECT_FALSE(parse_ros_discovery_info(kind));
  // A name that is not UTF-8, and one with no NUL at its end.
  Sample latin(16, true);
  EXPECT_FALSE(parse_ros_discovery_info(latin.info(kRosParticipant, {{"/", "cam\xe9ra", {}, {}}}).bytes()));
  auto no_nul = good();
  no_nul[4 + 16 + 4 + 4 + 6] = 'x';  // "/robot"'s NUL
  EXPECT_FALSE(parse_ros_discovery_info(no_nul));
  // A node with no name.
  Sample unnamed(16, true);
  EXPECT_FALSE(parse_ros_discovery_info(unnamed.info(kRosParticipant, {{"/", "", {}, {}}}).bytes()));
  // Bytes after the end: neither layout reads the whole sample.
  auto longer = good();
  longer.insert(longer.end(), {1, 2, 3, 4});
  EXPECT_FALSE(parse_ros_discovery_info(longer));
}

TEST(RosDiscoveryInfo, LimitsRefuseTheWholeSample) {
  std::vector<NodeSpec> many(5, NodeSpec{"/", "n", {kDepthReader, kDepthReader}, {}});
  auto bytes = Sample(16, true).info(kRosParticipant, many).bytes();
  EXPECT_TRUE(parse_ros_discovery_info(bytes));
  EXPECT_FALSE(parse_ros_discovery_info(bytes, RosInfoLimits{.nodes = 4}));
  EXPECT_FALSE(parse_ros_discovery_info(bytes, RosInfoLimits{.endpoints = 9}));
  EXPECT_FALSE(parse_ros_discovery_info(bytes, RosInfoLimits{.bytes = bytes.size() - 1}));
  // A count far beyond the bytes there: refused before anything is made of it.
  Sample huge(24, true);
  huge.gid(kRosParticipant).u32(1).text("/").text("n").u32(0xffffffffu);
  EXPECT_FALSE(parse_ros_discovery_info(huge.bytes()));
}

TEST(RosDiscoveryInfo, CutOrFlippedSamplesNeverReadPastTheirEnd) {
  // Seeded: every prefix of a good sample, then random byte flips; under ASan a
  // read past the end fails the run.
  std::mt19937 rng(20261204);
  for (const std::size_t gid_size : {std::size_t{24}, std::size_t{16}}) {
    const auto good = Sample(gid_size, true).info(kRosParticipant, kTwoNodes).bytes();
    for (std::size_t n = 0; n + 4 <= good.size(); ++n) {
      const std::vector<unsigned char> cut(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(n));
      // A cut ends a count or a string early; only a Humble sample cut after its
      // GUID's first 20 octets reads, rightly, as an Iron one with no node.
      if (auto info = parse_ros_discovery_info(cut)) {
        EXPECT_TRUE(info->nodes.empty()) << n;
      }
    }
    for (int round = 0; round < 5000; ++round) {
      auto bytes = good;
      for (int flips = 1 + static_cast<int>(rng() % 4); flips > 0; --flips)
        bytes[4 + rng() % (bytes.size() - 4)] = static_cast<unsigned char>(rng());
      if (auto info = parse_ros_discovery_info(bytes)) {
        EXPECT_LE(info->nodes.size(), RosInfoLimits{}.nodes);
      }
    }
  }
}

TEST(ParticipantBookRosNodes, AClientIsNamedByTheNodesOwningItsEndpointsOnTheCamera) {
  ParticipantBook book;
  book.endpoint_alive(kServer, kServer.substr(0, 27) + "00000102", "rt/" + kRoot + "_Depth", false, "T0");
  book.endpoint_alive(kRosParticipant, kDepthReader, "rt/" + kRoot + "_Depth", true, "T1");
  book.endpoint_alive(kRosParticipant, kImuWriter, "rt/imu", false, "T1");
  auto info = parse_ros_discovery_info(Sample(24, true).info(kRosParticipant, kTwoNodes).bytes());
  ASSERT_TRUE(info);
  ASSERT_TRUE(book.ros_nodes(info->participant, info->nodes));
  auto c = book.clients(kRoot, {kServer});
  ASSERT_EQ(c.clients.size(), 1u);
  // The imu filter shares the process, not the camera.
  EXPECT_EQ(c.clients[0].ros_nodes, std::vector<std::string>{"/robot/viewer"});
  EXPECT_EQ(c.clients[0].streams, std::vector<std::string>{"Depth"});

  // Its latest sample says all its nodes: the viewer moved to another namespace.
  book.ros_nodes(kRosParticipant, {RosNode{"/lab/viewer", {kDepthReader}}});
  EXPECT_EQ(book.clients(kRoot, {kServer}).clients[0].ros_nodes, std::vector<std::string>{"/lab/viewer"});
  // Gone with its participant; back without a sample, it is no ROS node.
  book.gone(kRosParticipant, "T2");
  book.endpoint_alive(kRosParticipant, kDepthReader, "rt/" + kRoot + "_Depth", true, "T3");
  EXPECT_TRUE(book.clients(kRoot, {kServer}).clients[0].ros_nodes.empty());
}

TEST(ParticipantBookRosNodes, StayWithinTheirBounds) {
  ParticipantBook book(/*max_alive=*/3, /*max_gone=*/2, rsd::dds::EndpointLimits{.per_domain = 10});
  const auto guid = [](int n) { return "0110" + std::to_string(1000 + n) + ".00000000.00000000.000001c1"; };
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(book.ros_nodes(guid(i), {RosNode{"/n", {guid(i)}}}));
  EXPECT_FALSE(book.ros_nodes(guid(3), {RosNode{"/n", {guid(3)}}}));  // a fourth participant
  book.gone(guid(0), "T");
  EXPECT_TRUE(book.ros_nodes(guid(3), {RosNode{"/n", {guid(3)}}}));
  // As many node endpoints as the domain keeps endpoints: 3 kept, 8 more refused.
  EXPECT_FALSE(book.ros_nodes(guid(4), {RosNode{"/n", std::vector<std::string>(8, guid(4))}}));
  // A participant's new sample replaces its old one's count.
  EXPECT_TRUE(book.ros_nodes(guid(1), {RosNode{"/n", std::vector<std::string>(8, guid(1))}}));
}

TEST(RosDiscoveryInfo, NodeNamesAreAlwaysAbsolute) {
  using rsd::dds::full_node_name;
  EXPECT_EQ(full_node_name("/", "viewer"), "/viewer");
  EXPECT_EQ(full_node_name("/robot", "viewer"), "/robot/viewer");
  EXPECT_EQ(full_node_name("/robot/", "viewer"), "/robot/viewer");
  EXPECT_EQ(full_node_name("", "viewer"), "/viewer");
  EXPECT_EQ(full_node_name("robot", "viewer"), "/robot/viewer");  // not ROS 2's, read as absolute
}
