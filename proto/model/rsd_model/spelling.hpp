// Every key and enumerator name of the API's documents (proto/openapi.yaml), free of
// any JSON library: the daemon writes its documents with them (nlohmann, rsd_model's
// to_json) and the C++ client reads them with them (RapidJSON, client/src), so a key
// is spelled once for both sides although each binary has its own JSON library.
#pragma once

#include "rsd_model/names.hpp"

#include <optional>
#include <string_view>

namespace rsd::model {

// Every key the daemon writes at the top level of a device. Nothing else in the
// daemon or the client spells them.
namespace key {
inline constexpr const char* id = "id";
inline constexpr const char* source = "source";
inline constexpr const char* sources = "sources";
inline constexpr const char* domain = "domain";
inline constexpr const char* topic_root = "topic-root";
inline constexpr const char* name = "name";
inline constexpr const char* serial = "serial";
inline constexpr const char* product_line = "product-line";
inline constexpr const char* product_id = "product-id";
inline constexpr const char* fw_version = "fw-version";
inline constexpr const char* recovery = "recovery";
inline constexpr const char* first_seen = "first-seen";
inline constexpr const char* last_seen = "last-seen";
inline constexpr const char* server = "server";
inline constexpr const char* usb = "usb";
inline constexpr const char* host = "host";
inline constexpr const char* warnings = "warnings";
inline constexpr const char* merged_into = "merged-into";
// A DDS camera's clients, in short (written only while it has one; rsd_model/clients.hpp).
inline constexpr const char* in_use = "in-use";
// A DDS camera whose server's lease ran out, kept listed for the removal grace.
inline constexpr const char* unresponsive = "unresponsive";
// A DDS camera whose notification set was (not) received whole when the daemon
// subscribed, and how far it got when not (written once the daemon knows).
inline constexpr const char* ready = "ready";
inline constexpr const char* ready_stage = "ready-stage";
// Inside "usb": the camera's device files on this host (what `rs-discover clients`
// looks for among the processes' open files).
inline constexpr const char* device_nodes = "device-nodes";
}  // namespace key

// The keys inside a device's "server", "usb", "host" and "in-use".
namespace part_key {
inline constexpr const char* participant_guid = "participant-guid";
inline constexpr const char* participant_name = "participant-name";
inline constexpr const char* addresses = "addresses";
inline constexpr const char* writer_guid = "writer-guid";
inline constexpr const char* bus = "bus";
inline constexpr const char* address = "address";
inline constexpr const char* port_path = "port-path";
inline constexpr const char* speed = "speed";
inline constexpr const char* vid = "vid";
inline constexpr const char* pid = "pid";
inline constexpr const char* speed_mbps = "speed-mbps";
inline constexpr const char* usb_version = "usb-version";
inline constexpr const char* sysfs_path = "sysfs-path";
inline constexpr const char* name = "name";
inline constexpr const char* clients = "clients";
inline constexpr const char* streaming = "streaming";
}  // namespace part_key

// A domain's entry of /v1/domains and /healthz (status.hpp).
namespace status_key {
inline constexpr const char* domain = "domain";
inline constexpr const char* state = "state";
inline constexpr const char* participant_guid = "participant-guid";
inline constexpr const char* error = "error";
inline constexpr const char* devices = "devices";
inline constexpr const char* accepted = "accepted";
inline constexpr const char* stopping = "stopping";
inline constexpr const char* rejected = "rejected";
inline constexpr const char* rebuilds = "rebuilds";
inline constexpr const char* refreshes = "refreshes";
inline constexpr const char* lost_servers = "lost-servers";
inline constexpr const char* writers = "device-info-writers";
inline constexpr const char* writers_refused = "writers-refused";
inline constexpr const char* endpoints_refused = "endpoints-refused";
inline constexpr const char* interfaces = "interfaces";
inline constexpr const char* name = "name";
inline constexpr const char* addresses = "addresses";
inline constexpr const char* network_changes = "network-changes";
inline constexpr const char* network_changed_at = "network-changed-at";
inline constexpr const char* complete = "complete";
inline constexpr const char* status = "status";
inline constexpr const char* version = "version";
inline constexpr const char* generation = "generation";
inline constexpr const char* usb = "usb";
inline constexpr const char* http = "http";
inline constexpr const char* listening = "listening";
inline constexpr const char* configured = "configured";
inline constexpr const char* from = "from";
inline constexpr const char* agrees = "agrees";
inline constexpr const char* expected = "expected";
}  // namespace status_key

// A DDS peer's identity, in a participant entry and in a camera's client alike.
namespace peer_key {
inline constexpr const char* guid = "guid";
inline constexpr const char* name = "name";
inline constexpr const char* vendor = "vendor";
inline constexpr const char* vendor_id = "vendor-id";
inline constexpr const char* addresses = "addresses";
inline constexpr const char* host = "host";
inline constexpr const char* process = "process";
inline constexpr const char* pid = "pid";
}  // namespace peer_key

// A camera's description (GET /v1/devices/{id}/description).
namespace description_key {
inline constexpr const char* streams = "streams";
inline constexpr const char* device_options = "device-options";
inline constexpr const char* extrinsics = "extrinsics";
inline constexpr const char* presets = "presets";
inline constexpr const char* name = "name";
inline constexpr const char* type = "type";
inline constexpr const char* sensor_name = "sensor-name";
inline constexpr const char* profiles = "profiles";
inline constexpr const char* default_profile = "default-profile";
inline constexpr const char* metadata_enabled = "metadata-enabled";
inline constexpr const char* options = "options";
inline constexpr const char* intrinsics = "intrinsics";
inline constexpr const char* embedded_filters = "embedded-filters";
inline constexpr const char* fps = "fps";
inline constexpr const char* format = "format";
inline constexpr const char* width = "width";
inline constexpr const char* height = "height";
inline constexpr const char* value = "value";
inline constexpr const char* min = "min";
inline constexpr const char* max = "max";
inline constexpr const char* step = "step";
inline constexpr const char* default_value = "default";
inline constexpr const char* description = "description";
inline constexpr const char* json = "json";
inline constexpr const char* from = "from";
inline constexpr const char* to = "to";
inline constexpr const char* rotation = "rotation";
inline constexpr const char* translation = "translation";
}  // namespace description_key

// A participant entry of /v1/participants (participant.hpp).
namespace participant_key {
inline constexpr const char* domain = "domain";
inline constexpr const char* lease_seconds = "lease-seconds";
inline constexpr const char* state = "state";
inline constexpr const char* first_seen = "first-seen";
inline constexpr const char* last_seen = "last-seen";
inline constexpr const char* device_info_writers = "device-info-writers";
inline constexpr const char* devices = "devices";
inline constexpr const char* silent_writers = "silent-writers";
inline constexpr const char* never_announced = "never-announced";
inline constexpr const char* topic_roots = "topic-roots";
inline constexpr const char* endpoints = "endpoints";
}  // namespace participant_key

// A camera's clients (GET /v1/devices/{id}/clients; clients.hpp).
namespace clients_key {
inline constexpr const char* clients = "clients";
inline constexpr const char* streams = "streams";
inline constexpr const char* since = "since";
inline constexpr const char* ros_nodes = "ros-nodes";
}  // namespace clients_key

// The expected cameras' report (GET /v1/expected, /healthz "expected"; expected.hpp).
namespace expected_key {
inline constexpr const char* name = "name";
inline constexpr const char* serial = "serial";
inline constexpr const char* topic_root = "topic-root";
inline constexpr const char* id = "id";
inline constexpr const char* last_seen = "last-seen";
inline constexpr const char* reason = "reason";
inline constexpr const char* complete = "complete";
inline constexpr const char* expected = "expected";
inline constexpr const char* present = "present";
inline constexpr const char* missing = "missing";
}  // namespace expected_key

// remote_usb ("remote-usb"): a camera plugged into another host's USB, which that
// host's daemon shares over DDS (docs/sharing.md). Never merged with a local sighting.
enum class Source { dds, usb, remote_usb };
constexpr const char* to_string(Source source) {
  switch (source) {
    case Source::dds: return "dds";
    case Source::usb: return "usb";
    case Source::remote_usb: return "remote-usb";
  }
  return "unknown";  // not reached: every enumerator is named above
}
// Exact: "dds", "usb", "remote-usb".
constexpr std::optional<Source> parse_source(std::string_view text) {
  for (Source s : {Source::dds, Source::usb, Source::remote_usb})
    if (text == to_string(s)) return s;
  return std::nullopt;
}

// What a user is told first about a camera: recovery firmware wins over a warning.
enum class DeviceState { ok, warning, recovery };
constexpr const char* to_string(DeviceState state) {
  switch (state) {
    case DeviceState::ok: return "ok";
    case DeviceState::warning: return "warning";
    case DeviceState::recovery: return "recovery";
  }
  return "unknown";  // not reached
}

// A domain's life: settling (participant made, reader not yet created) ->
// running; rebuilding while its participant is made anew; failed when it cannot
// be joined; stopped once left.
enum class DomainState { settling, running, rebuilding, failed, stopped };

constexpr std::string_view to_string(DomainState state) {
  switch (state) {
    case DomainState::settling: return "settling";
    case DomainState::running: return "running";
    case DomainState::rebuilding: return "rebuilding";
    case DomainState::failed: return "failed";
    case DomainState::stopped: return "stopped";
  }
  return "stopped";  // not reached: every enumerator is named above
}

constexpr std::optional<DomainState> parse_domain_state(std::string_view name) {
  return parse_name(name, {DomainState::settling, DomainState::running, DomainState::rebuilding,
                           DomainState::failed, DomainState::stopped});
}

// The DDS implementation, from the first two bytes of the GUID (the RTPS vendor
// id; measured: realdds on Fast DDS 01.0f, Cyclone 0.10 and 0.11 01.10).
enum class Vendor { fast_dds, cyclone_dds, rti_connext, opendds, other };

constexpr std::string_view to_string(Vendor v) {
  switch (v) {
    case Vendor::fast_dds: return "fast-dds";
    case Vendor::cyclone_dds: return "cyclone-dds";
    case Vendor::rti_connext: return "rti-connext";
    case Vendor::opendds: return "opendds";
    case Vendor::other: return "other";
  }
  return "other";  // not reached
}
constexpr std::optional<Vendor> parse_vendor(std::string_view name) {
  return parse_name(name, {Vendor::fast_dds, Vendor::cyclone_dds, Vendor::rti_connext, Vendor::opendds, Vendor::other});
}

// alive: its lease holds. gone: it said goodbye, or its lease ran out (a crash,
// a cut cable, a firewall that let its first packets through): Cyclone DDS
// disposes the participant alike in both cases (measured with 0.10.2: a realdds
// server killed with SIGKILL and one deleted by its owner look the same), so the
// API does not pretend to tell them apart.
enum class ParticipantState { alive, gone };

constexpr std::string_view to_string(ParticipantState s) {
  switch (s) {
    case ParticipantState::alive: return "alive";
    case ParticipantState::gone: return "gone";
  }
  return "gone";  // not reached
}
constexpr std::optional<ParticipantState> parse_participant_state(std::string_view name) {
  return parse_name(name, {ParticipantState::alive, ParticipantState::gone});
}

}  // namespace rsd::model
