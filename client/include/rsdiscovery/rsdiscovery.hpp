// rsdiscovery: a thin client of rs-discoveryd, the daemon that keeps a live table of
// Intel RealSense cameras (found over DDS and USB).
//
// This is the whole public interface. It depends on the C++ standard library only:
// the device document the daemon sends is handed over as JSON text (Device::json) next
// to the fields most programs need, so callers are free to parse it with anything.
//
//   rsdiscovery::Client client;                       // default endpoint
//   for (const auto& d : client.list_devices())
//     std::cout << d.name << " " << d.serial << "\n";
//
// Every call that talks to the daemon throws rsdiscovery::Error on failure; its code()
// tells what the caller can do about it.
//
// Threads: a Client serialises its own requests (one connection); each watch runs on a
// thread of its own, which blocks SIGPIPE. A program that makes requests from its own
// threads while the daemon may go away should ignore SIGPIPE, as network programs do.
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
// member, so that Device keeps the layout programs built against librsdiscovery0 have.
RSDISCOVERY_API std::optional<SharingHost> sharing_host(const Device& device);

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
  // (ClientOptions::complete_timeout) ran out: cameras that are there may be missing.
  bool complete = true;
};

// DeviceFilter and WatchOptions (which holds one) grew `host` with the soname kept:
// they live in an inline namespace, so the calls that take them have new symbols, and
// the library still exports the earlier ones for programs built against the earlier
// layout (client/src/abi0_compat.cpp). Source code names them as before.
inline namespace filters2 {

// Filters of GET /v1/devices and /v1/events. Empty members do not filter. The daemon
// applies them (values compare case-insensitively); the library never filters again.
struct RSDISCOVERY_API DeviceFilter {
  std::optional<int> domain;
  std::vector<int> domains;  // more domains: a device on any of these and `domain` matches
  std::string product_line;
  std::string source;   // "dds", "usb" or "remote-usb" (another host's USB camera)
  std::string serial;   // exactly this serial, ignoring case
  std::string name;     // a name containing this, ignoring case ("d455")
  std::string address;  // a camera whose server (or, remote-usb, whose host) has this address
  // The USB cameras the daemon on the host of this name shares (remote-usb; the name
  // as that host announces it, field "host" of the device document), ignoring case.
  std::string host;
};

}  // namespace filters2

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

// ---------------------------------------------------------------------------------
// Watching

struct WatchStatus {
  bool connected = false;
  std::string message;  // why it disconnected, or where it connected
};

inline namespace filters2 {

struct WatchOptions {
  // Report every device present when the watch starts as a synthetic `added`.
  bool initial = false;
  // Resume after this event id (for example one saved by an earlier process).
  std::optional<std::uint64_t> last_event_id;
  // Only devices that match are watched (the daemon filters the list and the stream).
  DeviceFilter filter;
  // Reconnect (and resume) when the daemon goes away, for example across a restart.
  bool reconnect = true;
  std::chrono::milliseconds max_reconnect_delay{2000};
  // A stream silent for this long is taken as dead and reconnected (the daemon
  // sends keep-alive comments well within it).
  std::chrono::milliseconds idle_timeout{60000};
  // After a daemon restart (a resync), the watch waits this long at most for the
  // restarted daemon's first discovery to be over before it compares its list with the
  // view: so a camera that was there before and after the restart is not reported
  // removed and added again. 0: compare at once (cameras not heard from again yet then
  // show up as removed, and added a moment later). The first list is not waited for:
  // it is the starting point, and what arrives after it is reported as events.
  std::chrono::milliseconds complete_timeout{10000};
  // Told when the stream is lost and when it is back (pull-style watches too; the
  // push-style one takes its own on_status). Runs on the library's thread.
  std::function<void(const WatchStatus&)> on_status;
};

}  // namespace filters2

// Connection state changes of a watch, for logging; never required.
class WatchCore;  // the library's insides

// A running watch, in pull style: next() blocks for the next event. The stream keeps
// a consistent view of the table across reconnects: after a gap the daemon cannot
// fill (a daemon restart), the library re-lists and reports the difference as
// synthetic events, so no addition or removal is lost.
class RSDISCOVERY_API Watch {
 public:
  Watch(Watch&&) noexcept;
  Watch& operator=(Watch&&) noexcept;
  ~Watch();  // stops

  // The next event, or nothing when `timeout` passes first or the watch was stopped.
  // Throws Error when the watch ended on an error it could not recover from
  // (permission denied, version mismatch, malformed reply; not_running only when
  // reconnect is off).
  std::optional<Event> next(std::chrono::milliseconds timeout);
  std::optional<Event> next();  // waits without limit; nothing once stopped

  void stop();  // from any thread; next() then returns nothing
  bool stopped() const;
  std::uint64_t last_event_id() const;  // to resume from, in a later watch
  std::vector<Device> devices() const;  // the view as tracked now

  // Range-for support: `for (const Event& e : watch)` runs until stop() or an error.
  class iterator {
   public:
    using iterator_category = std::input_iterator_tag;
    using value_type = Event;
    using difference_type = std::ptrdiff_t;
    using pointer = const Event*;
    using reference = const Event&;
    iterator() = default;
    explicit iterator(Watch* watch) : watch_(watch) { ++*this; }
    reference operator*() const { return *current_; }
    pointer operator->() const { return &*current_; }
    iterator& operator++() {
      current_ = watch_->next();
      if (!current_) watch_ = nullptr;
      return *this;
    }
    void operator++(int) { ++*this; }
    bool operator==(const iterator& other) const { return watch_ == other.watch_; }
    bool operator!=(const iterator& other) const { return watch_ != other.watch_; }

   private:
    Watch* watch_ = nullptr;
    std::optional<Event> current_;
  };
  iterator begin() { return iterator(this); }
  iterator end() { return iterator(); }

 private:
  friend class Client;
  explicit Watch(std::shared_ptr<WatchCore> core);
  std::shared_ptr<WatchCore> core_;
};

// A live copy of the daemon's device table in this process, kept by a thread of the
// library from the event stream, as a Watch keeps its view, but with no events queued:
// devices() answers without asking the daemon (a copy of the view: tens of
// microseconds for 100 devices, where Client::list() is a round trip to the daemon).
// For a program that lists often: a dashboard, a control loop, a health check. It
// holds the table as of the last event that arrived, a fraction of a millisecond
// behind the daemon (bench/run's fan-out row). When the daemon goes away it keeps the
// last view while it reconnects (connected() says so) and, after a restart, lists
// again and follows the new table. Made by Client::view().
class RSDISCOVERY_API DeviceView {
 public:
  DeviceView(DeviceView&&) noexcept;
  DeviceView& operator=(DeviceView&&) noexcept;
  ~DeviceView();  // stops

  // The devices as tracked now, in id order. Throws the error the view ended on
  // (permission denied, version mismatch, malformed reply; not_running only when
  // reconnect is off), or Error(cancelled) once stopped: a view that no longer
  // follows the table is never handed out as if it did.
  std::vector<Device> devices() const;
  bool connected() const;  // the event stream is open now (false while reconnecting)
  std::uint64_t last_event_id() const;
  void stop();  // from any thread

 private:
  friend class Client;
  explicit DeviceView(std::shared_ptr<WatchCore> core);
  std::shared_ptr<WatchCore> core_;
};

// A running watch in push style: the callback runs on a thread of the library's.
// An exception thrown by the callback stops the watch and is handed to on_error (or,
// without one, printed to stderr); wait() rethrows it as well.
class RSDISCOVERY_API Subscription {
 public:
  Subscription(Subscription&&) noexcept;
  Subscription& operator=(Subscription&&) noexcept;
  ~Subscription();  // stops and joins

  void stop();           // from any thread but the callback's own
  bool running() const;  // false once stopped or failed
  // Blocks until the watch ends (stop() or an error); rethrows the error, if any.
  void wait();
  std::uint64_t last_event_id() const;

 private:
  friend class Client;
  struct State;
  explicit Subscription(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

// ---------------------------------------------------------------------------------
// The client

struct ClientOptions {
  std::chrono::milliseconds connect_timeout{2000};
  std::chrono::milliseconds request_timeout{10000};
  // list(), list_devices(), get_device(), find_device(), wait_for() and wait_until()
  // first wait this long at most for the daemon to finish its first discovery (it
  // takes a few seconds after the daemon starts), so that a camera that is there is
  // never reported missing just because the daemon has not heard from it yet.
  // 0: answer at once from whatever the table holds.
  std::chrono::milliseconds complete_timeout{5000};
  // Called each time the daemon answers 503 with Retry-After (at its connection limit,
  // or making its DDS participant anew) and the library waits as told before asking
  // again, for up to 10 s in all: a sentence saying why and for how long, for a tool to
  // show its user. Runs on the calling thread; empty: wait silently.
  std::function<void(const std::string&)> on_busy;
};

class RSDISCOVERY_API Client {
 public:
  Client();  // Endpoint::from_environment()
  explicit Client(Endpoint endpoint, ClientOptions options = {});
  explicit Client(const std::string& endpoint, ClientOptions options = {});
  Client(Client&&) noexcept;
  Client& operator=(Client&&) noexcept;
  ~Client();

  const Endpoint& endpoint() const;

  // The devices, with the generation and whether the table was complete (see
  // ClientOptions::complete_timeout for the wait that comes first). One request to the
  // daemon each call; to list often, keep a view() instead.
  DeviceList list(const DeviceFilter& filter = {});
  std::vector<Device> list_devices(const DeviceFilter& filter = {});  // list(filter).devices
  // list(filter) asking only for these keys of each device document ("id" always
  // comes; a dotted name is a key inside an object, "server.addresses"): less to send
  // and to parse when a few are shown. Members of other keys stay empty and
  // Device::json holds only these. A daemon older than the daemon's ?fields= (a 400)
  // is asked again for whole documents. An empty `fields` is list(filter).
  DeviceList list(const DeviceFilter& filter, const std::vector<std::string>& fields);
  // One device by its id, serial or topic-root (the daemon's lookup). get_device throws
  // Error(not_found) when absent: http_status() 410 for a camera that was here and left
  // (the message says why and when: see device_history()), 404 for one never seen.
  // Both throw Error(not_found) with http_status() 409 when a serial or topic-root
  // names several devices.
  Device get_device(const std::string& id);
  std::optional<Device> find_device(const std::string& id);  // nothing when absent, gone or never seen
  // Camera Discovery of a network camera (id, serial or topic-root): its streams with
  // their profiles and options, device options, extrinsics, asked of its realdds
  // server by the daemon without opening the camera. The first time for a camera it
  // may take up to the daemon's describe timeout (30 s; `timeout` bounds the wait
  // here, default 35 s). Throws Error(not_found) when there is no such camera or it is
  // USB-only (nothing describes those without opening them); Error(http_error) with
  // http_status() 409 for recovery firmware or a serial of several cameras, 504 when
  // the camera's server sent no complete description in time. A 503 (the daemon is
  // rebuilding its DDS participant) is asked again after its Retry-After.
  Description describe(const std::string& id,
                       std::chrono::milliseconds timeout = std::chrono::milliseconds(35000));
  // Who uses a network camera (id, serial or topic-root). Throws Error(not_found) when
  // there is no such camera or it is a USB one (the daemon cannot see processes).
  CameraClients clients(const std::string& id);
  std::vector<DomainStatus> domains();
  // Every participant heard on the daemon's domains (or on `domain` only), alive
  // first, then those gone, latest first.
  std::vector<Participant> participants(std::optional<int> domain = std::nullopt);
  Health health();
  std::string metrics();  // Prometheus text
  // A camera's comings and goings (GET /v1/devices/{id}/history: present or gone, its
  // changes, its removals by reason) as the daemon's JSON text; an Error not_found
  // (http_status() 404) for a camera never seen.
  std::string device_history(const std::string& id);
  // Every camera's changes after generation `since` (GET /v1/history), as JSON text.
  std::string history(std::uint64_t since = 0);
  // The expected cameras, present and missing. A daemon older than the route answers
  // 404: Error(not_found).
  Expected expected();

  // Waits until a device satisfying `predicate` is present (it may be already) and
  // returns it; nothing when `timeout` passes first. Like list(), it looks at the
  // complete table (bounded by ClientOptions::complete_timeout and by `timeout`).
  std::optional<Device> wait_for(const std::function<bool(const Device&)>& predicate,
                                 std::chrono::milliseconds timeout);
  // Waits until the devices matching `filter` satisfy `predicate` as a set; returns
  // that set, or nothing on timeout. `wait_until(f, [](auto& v){ return v.size() >= 2; })`
  std::optional<std::vector<Device>> wait_until(
      const DeviceFilter& filter,
      const std::function<bool(const std::vector<Device>&)>& predicate,
      std::chrono::milliseconds timeout);

  // Pull-style watch. Returns once the stream is open (and, without a last_event_id,
  // the view listed); throws at once when the daemon cannot be reached then. Later
  // disconnects are reconnected (options.reconnect).
  Watch watch(WatchOptions options = {});
  // A live copy of the table (see DeviceView), following the devices that match
  // options.filter. Returns once the stream is open and the view listed; throws at once
  // when the daemon cannot be reached then. options.initial does not apply (no events).
  DeviceView view(WatchOptions options = {});
  // Push-style watch: `on_event` runs on the library's thread for every event.
  Subscription watch(std::function<void(const Event&)> on_event, WatchOptions options = {},
                     std::function<void(std::exception_ptr)> on_error = {},
                     std::function<void(const WatchStatus&)> on_status = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rsdiscovery
