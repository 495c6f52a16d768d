// Fuzz target for ros_discovery_info samples: whatever a participant writes there,
// parse_ros_discovery_info answers without reading past the sample, and what it
// accepts stays within the limits and gives names a JSON document can carry.
//
// Input: one serialized sample as Cyclone hands it over (the 4-byte encapsulation
// header, then CDR).
#include "dds/ros_nodes.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstdlib>
#include <span>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const rsd::dds::RosInfoLimits limits{.bytes = 1 << 16, .nodes = 64, .endpoints = 512};
  const auto info = rsd::dds::parse_ros_discovery_info(std::span<const unsigned char>(data, size), limits);
  if (!info) return 0;
  std::size_t endpoints = 0;
  for (const auto& node : info->nodes) {
    endpoints += node.endpoints.size();
    if (node.name.empty() || node.name.front() != '/') std::abort();
    (void)nlohmann::json(node.name).dump();  // throws on invalid UTF-8: must never happen
  }
  if (info->nodes.size() > limits.nodes || endpoints > limits.endpoints || info->participant.size() != 35) std::abort();
  return 0;
}
