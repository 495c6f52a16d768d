// Who uses a DDS camera (proto/openapi.yaml `DeviceClients`, `InUse`): the
// participants other than its server with a reader or writer on its topics, the
// streams they read, and the small summary a device document carries. The daemon
// derives them from the DDS built-in topics and writes them through to_json.
#pragma once

#include "rsd_model/device.hpp"  // InUse
#include "rsd_model/participant.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace rsd::model {

struct Client {
  std::string guid;  // its participant's
  std::string name;  // its participant's entity name ("" when it gives none)
  Vendor vendor = Vendor::other;
  std::string vendor_id;
  std::vector<std::string> addresses;
  std::optional<std::string> host, process;  // Cyclone peers say them
  std::optional<std::int64_t> pid;
  std::string since;                 // ISO 8601 UTC: its first endpoint on the camera's topics
  std::vector<std::string> streams;  // the stream names it reads, sorted
  // The ROS 2 nodes (fully qualified) owning its endpoints on the camera's topics,
  // from its participant's ros_discovery_info; none when it is no ROS 2 node.
  std::vector<std::string> ros_nodes;
};

struct DeviceClients {
  std::vector<Client> clients;              // by GUID
  std::map<std::string, std::size_t> streams;  // streamed now: name -> readers
};

InUse summary_of(const DeviceClients& c);

nlohmann::json to_json(const Client& c);
nlohmann::json to_json(const DeviceClients& c);

}  // namespace rsd::model
