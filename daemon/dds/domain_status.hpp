// What a domain's DDS side reports about itself, for /v1/domains and /metrics.
// A plain value: DomainSession fills it, the API serialises it.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <string>

namespace rsd {

struct DomainStatus {
  int domain = 0;
  std::string state;             // "settling", "running", "rebuilding", "failed"
  std::string participant_guid;  // ours, "" until the participant exists
  std::string error;             // why the domain is "failed", else ""
  std::size_t devices = 0;       // devices of this domain now in the table
  std::uint64_t accepted = 0;    // device-info messages taken into the table
  std::uint64_t stopping = 0;    // 'stopping' messages honoured
  std::map<std::string, std::uint64_t> rejected;  // reason -> count
  std::uint64_t rebuilds = 0;    // times the participant was torn down and made anew
  std::uint64_t refreshes = 0;   // of those, made anew by itself to find a lost server again
  std::size_t lost_servers = 0;  // servers lost without 'stopping', still looked for
  // The domain's first discovery is over: its reader has existed long enough for
  // every server already on the network to have announced its devices (or the
  // domain failed, so nothing more will come). Until then a device list is partial.
  bool complete = false;
};

// Camera Discovery's answer for one device (GET /v1/devices/{id}/description):
// DomainSet gives it, the API serialises it.
struct DeviceDescription {
  enum class Outcome {
    ok,           // `description` holds the streams, options, extrinsics, presets
    not_found,    // no such device (or it left meanwhile)
    not_network,  // a USB-only camera: nothing describes it without opening it
    recovery,     // running its recovery firmware: no streams
    timeout,      // its server sent no whole set in time
    unavailable,  // the domain is starting or being made anew: ask again soon
  };
  Outcome outcome = Outcome::not_found;
  nlohmann::json description;
  std::string error;  // for the user, when not ok
};

}  // namespace rsd
