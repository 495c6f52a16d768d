// The ROS 2 nodes a participant holds, parsed from its ros_discovery_info sample
// (rmw_dds_common's ParticipantEntitiesInfo, proto/ros_discovery.idl): the names a
// camera's client is known by when it is a ROS 2 node, whose participant is named
// only "/". Pure: DomainSession hands in the serialized bytes Cyclone received.
#pragma once

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::dds {

struct RosNode {
  std::string name;                    // fully qualified: "/robot/viewer"
  std::vector<std::string> endpoints;  // the GUIDs of its readers and writers (guid_text)
};

struct RosParticipantInfo {
  std::string participant;  // the GUID the sample gives for its participant
  std::vector<RosNode> nodes;
};

// A sample is untrusted input: beyond these it is refused whole.
struct RosInfoLimits {
  std::size_t bytes = 1 << 20;
  std::size_t nodes = 256;       // a component container holds a few dozen
  std::size_t endpoints = 4096;  // all its nodes' GUIDs together (EndpointLimits::per_participant)
};

// One serialized sample as Cyclone gives it: the 4-byte encapsulation header, then
// plain CDR (XCDR1 or XCDR2, either byte order). ROS 2 Humble's GID holds 24
// octets and Iron's and later ones 16, and nothing in the sample says which: the
// layout that reads the whole sample (up to its final padding) is the one. Nothing
// when neither does, when a name is not UTF-8, or beyond a limit.
std::optional<RosParticipantInfo> parse_ros_discovery_info(std::span<const unsigned char> sample,
                                                           const RosInfoLimits& limits = {});

// "/robot" + "viewer" -> "/robot/viewer", "/" + "viewer" -> "/viewer"; always
// absolute ("robot" + "viewer" -> "/robot/viewer").
std::string full_node_name(std::string_view node_namespace, std::string_view node_name);

// A 16-byte DDS GUID as the daemon spells GUIDs: "0110a3b1.22c44e8f.7f000001.000001c1".
std::string guid_text(std::span<const unsigned char, 16> guid);

}  // namespace rsd::dds
