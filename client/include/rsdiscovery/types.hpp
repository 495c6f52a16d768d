// rsdiscovery/types.hpp: the values the daemon reports (devices, lists, filters,
// events, status documents) and the library's error; part of <rsdiscovery/rsdiscovery.hpp>,
// which is what programs include.
#pragma once

#include <rsdiscovery/expected.hpp>

#include <chrono>
#include <cstdint>
#include <exception>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#if defined(__GNUC__) || defined(__clang__)
#define RSDISCOVERY_API __attribute__((visibility("default")))
#else
#define RSDISCOVERY_API
#endif

namespace rsdiscovery {

// The library's version ("major.minor.patch").
RSDISCOVERY_API const char* version();

// ---------------------------------------------------------------------------------
// Errors

enum class ErrorCode {
  not_running,        // nothing listens at the endpoint (socket missing, refused)
  permission_denied,  // the socket exists but this user may not connect to it
  not_found,          // no such device
  timeout,            // a wait ran out of time, or the daemon did not answer in time
  malformed_reply,    // the daemon's answer is not what the API promises
  version_mismatch,   // the daemon does not speak this library's API version (v1)
  http_error,         // any other unexpected HTTP status
  bad_endpoint,       // the endpoint string cannot be understood
  cancelled,          // the call was stopped from another thread
};
RSDISCOVERY_API const char* to_string(ErrorCode code);

class RSDISCOVERY_API Error : public std::runtime_error {
 public:
  Error(ErrorCode code, const std::string& message, int http_status = 0)
      : std::runtime_error(message), code_(code), http_status_(http_status) {}
  ErrorCode code() const noexcept { return code_; }
  int http_status() const noexcept { return http_status_; }  // 0 when no HTTP reply

 private:
  ErrorCode code_;
  int http_status_;
};

// ---------------------------------------------------------------------------------
// Endpoint: where the daemon is.

struct RSDISCOVERY_API Endpoint {
  enum class Kind { unix_socket, http };
  Kind kind = Kind::unix_socket;
  std::string path;  // unix_socket: the socket's path
  std::string host;  // http: host name or address (IPv6 without brackets)
  int port = 0;      // http

  // "unix:/run/x.sock", "unix:///run/x.sock", "/run/x.sock" or "http://host:port".
  // Throws Error(bad_endpoint).
  static Endpoint parse(const std::string& text);
  // $RS_DISCOVERY_ENDPOINT when set and not empty, else default_socket().
  static Endpoint from_environment();
  // The daemon's own default (the same rule as the daemon's): $RUNTIME_DIRECTORY/api.sock
  // when set, else /run/rs-discoveryd/api.sock for root, else
  // $XDG_RUNTIME_DIR/rs-discoveryd.sock, else /tmp/rs-discoveryd-UID.sock; or the system
  // service's /run/rs-discoveryd/api.sock when only that exists.
  static Endpoint default_socket();

  std::string to_string() const;  // "unix:/path" or "http://host:port"
};

// ---------------------------------------------------------------------------------
// What the daemon reports.

struct ServerInfo {  // the realdds server that announced a DDS device
  std::string participant_guid;
  std::string participant_name;
  std::vector<std::string> addresses;
};

struct UsbInfo {  // where a USB device is plugged
  std::optional<int> bus;
  std::string port_path;
  std::string speed;
};

struct RSDISCOVERY_API Device {
  std::string id;                    // stable, URL-safe; the key for get_device()
  std::string source;                // "dds", "usb" or "remote-usb" (see sharing_host())
  std::vector<std::string> sources;  // when one camera is seen both ways; else {source}
  std::optional<int> domain;         // DDS domain (DDS devices)
  std::string topic_root;
  std::string name;
  std::string serial;
  std::string product_line;
  std::string product_id;
  std::string fw_version;
  bool recovery = false;
  std::string first_seen;  // ISO 8601, UTC
  std::string last_seen;
  std::optional<ServerInfo> server;
  std::optional<UsbInfo> usb;
  std::vector<std::string> warnings;  // plain-language, for example a USB 3 camera on a USB 2 link
  std::string warning;                // the first of warnings; empty when none
  std::string state;                  // "ok", "warning" (see warnings) or "recovery"
  std::string json;                   // the whole device document as the daemon sent it

  // Any top-level field of the document as JSON text ("" when absent), for fields
  // this struct does not name (for example "multicast-ip").
  std::string field(const std::string& key) const;
};

// Builds a Device from a device document (JSON object text). Throws
// Error(malformed_reply) when it is not one.
RSDISCOVERY_API Device parse_device(const std::string& json_text);

// The host whose daemon shares a remote-usb camera (another host's USB camera): the
// name and addresses it announces, and its daemon's DDS participant ("" when not said).
struct SharingHost {
  std::string name;
  std::vector<std::string> addresses;
  std::string participant_guid;
};
// The host of a remote-usb device; nothing for any other (also where its document has
// no readable "host": then a value with an empty name). A function rather than a
// member: a member would change the layout of Device, which most calls hand out.
RSDISCOVERY_API std::optional<SharingHost> sharing_host(const Device& device);

// A network camera's clients in short (its document's "in-use"): how many DDS
// participants use it and the streams read now; Client's clients() says who. Nothing
// for a camera with no client. A function, as sharing_host() is, for the same reason.
struct DeviceInUse {
  std::size_t clients = 0;
  std::vector<std::string> streaming;
};
RSDISCOVERY_API std::optional<DeviceInUse> in_use_of(const Device& device);

struct DomainStatus {
  int domain = 0;
  std::string state;
  std::string participant_guid;
  std::uint64_t devices = 0;
  std::uint64_t accepted = 0;
  std::map<std::string, std::uint64_t> rejected;  // reason -> count
  // The domain's first discovery is over (false for about the first 3 s after the
  // daemon joins it): until then its devices may be missing from the table.
  bool complete = true;
  std::string json;  // the whole entry
};

// A DDS participant the daemon hears on one of its domains (GET /v1/participants):
// realdds servers, librealsense and ROS programs, other DDS tools.
struct Participant {
  int domain = 0;
  std::string guid;
  std::string name;       // "" when it gives none
  std::string vendor;     // "fast-dds" (realdds), "cyclone-dds", "rti-connext", "opendds", "other"
  std::vector<std::string> addresses;
  std::string host, process;  // "" unless it says (Cyclone DDS peers do)
  std::optional<double> lease_seconds;
  std::string state;           // "alive" or "gone"
  std::string first_seen, last_seen;  // ISO 8601 UTC
  std::uint64_t device_info_writers = 0;
  std::uint64_t devices = 0;
  // A realdds server whose device writers matched but none of whose announcements
  // arrived: the network path or the server is at fault.
  bool never_announced = false;
  std::vector<std::string> topic_roots;  // of the cameras it announces
  // Its readers and writers the daemon discovered; none for a participant heard for
  // seconds means the unicast exchange after discovery does not get through.
  std::uint64_t endpoints = 0;
  std::string json;  // the whole entry
};

// A program using a network camera (GET /v1/devices/{id}/clients): a DDS participant
// other than the camera's server with a reader or writer on its topics.
struct CameraClient {
  std::string guid, name, vendor;
  std::vector<std::string> addresses;
  std::string host, process;  // "" unless it says (Cyclone DDS peers do)
  std::string since;          // ISO 8601 UTC: its first endpoint on the camera's topics
  std::vector<std::string> streams;  // the streams it reads
  // When it is a ROS 2 node (whose participant is named "/"): the nodes owning its
  // readers and writers on the camera's topics, fully qualified ("/robot/viewer").
  std::vector<std::string> ros_nodes;
};

struct CameraClients {
  std::vector<CameraClient> clients;
  std::map<std::string, std::uint64_t> streams;  // read now: name -> readers
  std::string json;                              // the whole document
};

struct Health {
  std::string status;  // "ok" when healthy
  std::string version;
  std::uint64_t devices = 0;
  // Every domain has finished its first discovery, so `devices` is no longer
  // short of cameras that are there (false in the seconds after the daemon starts).
  bool complete = true;
  std::string json;
};

// ---------------------------------------------------------------------------------
// Camera Discovery: what a network camera can do, without opening it
// (GET /v1/devices/{id}/description)

struct StreamProfile {
  int fps = 0;
  std::string format;  // realdds' encoding, e.g. "16UC1", "rgb8"; "" for motion streams
  int width = 0;       // 0 for motion streams
  int height = 0;
};

struct CameraOption {
  std::string name;
  std::string value;        // JSON text of the current value; "" when not given
  std::string description;  // "" when not given
  std::string json;         // the option as the camera's server declared it (range, default ...)
};

struct CameraStream {
  std::string name;    // e.g. "Depth", "Infrared 1"
  std::string type;    // depth, color, ir, motion ...
  std::string sensor;  // e.g. "Stereo Module"
  std::vector<StreamProfile> profiles;
  std::optional<StreamProfile> default_profile;
  bool metadata = false;  // the stream carries frame metadata
  std::vector<CameraOption> options;
};

struct Description {
  std::vector<CameraStream> streams;
  std::vector<CameraOption> device_options;
  std::string json;  // the whole document (extrinsics, presets, intrinsics ...)
};

// Builds a Description from the daemon's document (JSON object text). Throws
// Error(malformed_reply) when it is not one.
RSDISCOVERY_API Description parse_description(const std::string& json_text);

// One answer of GET /v1/devices.
struct DeviceList {
  std::vector<Device> devices;
  std::uint64_t generation = 0;  // the table's generation the list was taken at
  // False when the daemon had not finished its first discovery and the wait for it
  // (ClientOptions::complete_timeout()) ran out: cameras that are there may be missing.
  bool complete = true;
};

struct Event {
  enum class Type { added, changed, removed };
  Type type = Type::added;
  // The daemon's event id (its generation counter). Events the library derived
  // itself from a re-list (synthetic) carry the id of the point they stand for.
  std::uint64_t id = 0;
  bool synthetic = false;  // true: derived from a re-list, not sent by the daemon
  Device device;           // after the event; for removed, as it was last seen
};
RSDISCOVERY_API const char* to_string(Event::Type type);

}  // namespace rsdiscovery
