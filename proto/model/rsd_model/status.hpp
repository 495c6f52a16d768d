// The API's status documents as types: a domain's entry of /v1/domains
// (proto/openapi.yaml `DomainStatus`) and /healthz (`Health`). The daemon fills
// them from its sources and writes them through to_json, with the keys of
// spelling.hpp, which the C++ client reads them by.
#pragma once

#include "rsd_model/expected.hpp"
#include "rsd_model/names.hpp"

#include "rsd_model/spelling.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::model {


// A network interface a domain is joined on, with its IPv4 addresses.
struct InterfaceStatus {
  std::string name;
  std::vector<std::string> addresses;
  bool operator==(const InterfaceStatus&) const = default;
};

struct DomainStatus {
  int domain = 0;
  DomainState state = DomainState::stopped;
  std::string participant_guid;  // the daemon's own, "" until the participant exists
  std::string error;             // why the domain is failed, else ""
  std::size_t devices = 0;       // devices of this domain now in the table
  std::uint64_t accepted = 0;    // device-info messages taken into the table
  std::uint64_t stopping = 0;    // 'stopping' messages honoured
  std::map<std::string, std::uint64_t> rejected;  // reason -> count
  std::uint64_t rebuilds = 0;    // times the participant was torn down and made anew
  std::uint64_t refreshes = 0;   // of those, made anew by itself to find a lost server again
  std::size_t lost_servers = 0;  // servers lost without 'stopping', still looked for
  std::size_t writers = 0;       // device-info writers matched and followed
  std::map<std::string, std::uint64_t> writers_refused;  // over a writer cap: reason -> writers
  // Readers and writers (any topic) refused by an endpoint cap, or kept without their
  // too long or too many topic names: reason -> endpoints
  std::map<std::string, std::uint64_t> endpoints_refused;
  // The interfaces the daemon joined the domain on (loopback when nothing else is
  // usable); empty when the user's Cyclone configuration names them.
  std::vector<InterfaceStatus> interfaces;
  std::uint64_t network_changes = 0;  // times it was joined anew for a network change
  std::string network_changed_at;     // the last of them (RFC 3339), "" never
  // The domain's first discovery is over: its reader has existed long enough for
  // every server already on the network to have announced its devices (or the
  // domain failed, so nothing more will come). Until then a device list is partial.
  bool complete = false;
};

// The local USB source as /healthz shows it.
struct UsbHealth {
  std::string state = "off";  // off, stopped, unavailable, hotplug, polling
  std::optional<std::size_t> devices;  // absent when off
  std::optional<std::string> error;    // why unavailable
};

// The HTTP listener as /healthz shows it. Under socket activation the socket unit
// decides the address, whatever the configuration says; `agrees` is false when the
// configuration names another one (it was changed in one place only).
struct HttpHealth {
  std::string listening;        // "HOST:PORT" ("[V6]:PORT"); "" without HTTP
  std::string configured;       // the configuration's "http": "HOST:PORT", "off"; "" when unnamed (the default)
  std::string from = "config";  // "config": the daemon bound it; "systemd": passed by the socket unit
  bool agrees = true;
};

struct Health {
  std::string status = "ok";
  std::string version;
  std::size_t devices = 0;
  std::uint64_t generation = 0;
  // Every domain's first discovery is over; "ok" says the daemon works, this
  // whether its device count is final yet (false for the first seconds).
  bool complete = false;
  UsbHealth usb;
  std::optional<HttpHealth> http;  // absent from older daemons
  // The expected cameras (`expect`) and which are listed; absent when none are expected.
  std::optional<ExpectedReport> expected;
};

// A document that is not what the spec says (a missing or mistyped key).
struct MalformedDocument : std::runtime_error {
  using std::runtime_error::runtime_error;
};

nlohmann::json to_json(const DomainStatus& status);
nlohmann::json to_json(const Health& health);

}  // namespace rsd::model
