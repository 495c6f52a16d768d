// A DDS participant as /v1/participants shows it (proto/openapi.yaml
// `Participant`): who is on a joined domain, seen from the daemon's own
// participant, whether or not it announces cameras. The daemon fills it from
// Cyclone's DCPSParticipant reader and its device-info bookkeeping and writes it
// through to_json.
#pragma once

#include "rsd_model/status.hpp"  // MalformedDocument

#include "rsd_model/spelling.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::model {

// "01.0f" from a GUID as the API writes it ("010f78fd.3e2482db...."); "" if it is not one.
std::string vendor_id_of(std::string_view guid);
Vendor vendor_of(std::string_view vendor_id);


struct Participant {
  int domain = 0;
  std::string guid;
  std::string name;       // its entity name ("" when it gives none)
  Vendor vendor = Vendor::other;
  std::string vendor_id;  // "01.0f"
  std::vector<std::string> addresses;  // the hosts of its unicast locators, as Cyclone heard them
  std::optional<std::string> host;     // Cyclone peers name their host, process and pid
  std::optional<std::string> process;
  std::optional<std::int64_t> pid;
  std::optional<double> lease_seconds;  // the liveliness lease it announced
  ParticipantState state = ParticipantState::alive;
  std::string first_seen;  // ISO 8601 UTC
  std::string last_seen;   // now while alive; when it went
  // Its writers on realsense/device-info matched by the daemon, the devices they
  // announced, and those that matched long ago (the daemon's silent grace) and
  // never wrote. A realdds server has one such writer that never writes by design
  // (it only watches for readers); more than one, with no device, is a server
  // whose announcements do not arrive.
  std::size_t device_info_writers = 0;
  std::size_t devices = 0;
  std::size_t silent_writers = 0;
  std::vector<std::string> topic_roots;  // of the devices it announces
  // Its readers and writers (on any topic) the daemon's participant discovered.
  // Every DDS program has some; a participant alive for seconds with none was
  // heard over multicast while the unicast exchange that follows never got
  // through (a firewall dropping the domain's unicast ports, measured).
  std::size_t endpoints = 0;
  // A realdds server whose device-info writers matched and never announced a
  // device: silent writers and no device (the cause is on the network path, or
  // the server is stuck; the daemon has already asked it to announce again).
  bool never_announced = false;
};

nlohmann::json to_json(const Participant& p);

}  // namespace rsd::model
