// The device document of the API (proto/openapi.yaml, `Device`) as a type. The daemon
// builds its documents through it: one to_json, one from_json, and the keys of
// spelling.hpp (the C++ client reads the same documents by them, with its own JSON
// library: client/src/device_list.cpp).
//
// Round trip: to_json(device_from_json(doc)) == doc for any JSON object. A DDS device
// carries the camera's realdds device-info verbatim, and a peer may send keys of its
// own, or known keys with unexpected types; whatever the typed members cannot hold as
// it is stays in `extra`, untouched, so reading a document never loses or alters it.
#pragma once

#include "rsd_model/spelling.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::model {



// The realdds server that announced a DDS device (the latest one, when several do).
// Members are optional because a device-info that arrived without a known writer
// (never in practice, but the daemon allows for it) is served with "server": {}.
struct Server {
  std::optional<std::string> participant_guid;
  std::optional<std::string> participant_name;
  std::optional<std::vector<std::string>> addresses;
  std::optional<std::string> writer_guid;
  bool operator==(const Server&) const = default;
};

// Where a USB device is plugged, from its descriptor and sysfs.
struct Usb {
  int bus = 0;
  int address = 0;
  std::string port_path;  // the kernel's name, "2-1.4"
  std::string speed;      // "low", "full", "high", "super", "super-plus", "unknown"
  std::string vid, pid;   // 4 upper-case hex digits
  std::optional<double> speed_mbps;      // written as an integer when it is whole
  std::optional<std::string> usb_version;  // "3.20"
  std::optional<std::string> sysfs_path;
  std::vector<std::string> device_nodes;  // /dev/bus/usb/BBB/DDD first; empty: not written
  bool operator==(const Usb&) const = default;
};

// The host whose daemon shares a remote-usb camera: the name it gives, the
// addresses it lists, and its DDS participant.
struct Host {
  std::string name;
  std::vector<std::string> addresses;
  std::optional<std::string> participant_guid;
  bool operator==(const Host&) const = default;
};

// Who uses a DDS camera, in short: its clients (participants other than its server on
// its topics) and the streams some client reads now (sorted).
struct InUse {
  std::size_t clients = 0;
  std::vector<std::string> streaming;
  bool operator==(const InUse&) const = default;
};

struct Device {
  // Declared, so that a Device is never built from a brace list: `{{"name", "x"}}` is a
  // JSON document wherever both are taken (DeviceTable::upsert).
  Device() = default;

  std::string id;  // empty in a source's sighting: the table sets it
  std::optional<Source> source;
  std::vector<Source> sources;  // set by the table; empty: not written
  std::optional<int> domain;    // DDS
  std::optional<std::string> topic_root;
  std::optional<std::string> name;
  std::optional<std::string> serial;
  std::optional<std::string> product_line;
  std::optional<std::string> product_id;
  std::optional<std::string> fw_version;
  std::optional<bool> recovery;
  std::optional<std::string> first_seen;  // ISO 8601 UTC, set by the table
  std::optional<std::string> last_seen;
  std::optional<Server> server;  // DDS
  std::optional<Usb> usb;        // USB (a remote-usb camera: where it is plugged on its host)
  std::optional<Host> host;      // remote-usb
  std::vector<std::string> warnings;  // plain-language; empty: not written
  std::optional<std::string> merged_into;  // on a `removed` entry that joined another
  std::optional<InUse> in_use;             // DDS, while it has a client
  std::optional<bool> unresponsive;        // DDS, during the removal grace (true only)
  std::optional<bool> ready;               // DDS, once a description fetch concluded
  std::optional<std::string> ready_stage;  // DDS, while not ready: "stream 1 of 3" ...
  // Every other key, verbatim (the camera's own device-info keys; and a known key whose
  // value is not of the type above). Always an object.
  nlohmann::json extra = nlohmann::json::object();

  DeviceState state() const;
  bool seen_by(Source s) const;  // source or any of sources
  // The lookup rule of GET /v1/devices/{key}, the clients and the CLI: after the id
  // (which the table answers itself), a serial or a topic-root names a device.
  bool named_by(std::string_view key) const;
  bool used() const { return in_use && in_use->clients > 0; }
  // Member by member, `extra` as JSON: equal devices write equal documents.
  bool operator==(const Device&) const = default;
};

nlohmann::json to_json(const Device& device);
nlohmann::json to_json(const Server& server);  // the "server" part alone (kept per announcer)
nlohmann::json to_json(const Host& host);
nlohmann::json to_json(const InUse& in_use);
// Never throws (see the round trip above). Callers that need a device check first that
// `doc` is an object with a string "id"; anything else gives an empty Device.
Device device_from_json(const nlohmann::json& doc);

// nlohmann's conversions, so `nlohmann::json j = device;` and `j.get<Device>()` work.
inline void to_json(nlohmann::json& j, const Device& d) { j = to_json(d); }
inline void from_json(const nlohmann::json& j, Device& d) { d = device_from_json(j); }

}  // namespace rsd::model
