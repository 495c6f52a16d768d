// rsdiscovery: a thin client of rs-discoveryd, the daemon that keeps a live table of
// Intel RealSense cameras (found over DDS and USB).
//
// This header, with types.hpp, options.hpp and watch.hpp which it includes, is the whole public
// interface. It depends on the C++ standard library only: the device document the
// daemon sends is handed over as JSON text (Device::json) next to the fields most
// programs need, so callers are free to parse it with anything.
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

#include <rsdiscovery/options.hpp>
#include <rsdiscovery/types.hpp>
#include <rsdiscovery/watch.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace rsdiscovery {

// ---------------------------------------------------------------------------------
// The client

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
  // ClientOptions::complete_timeout() for the wait that comes first). One request to the
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
  // there is no such camera or it is a USB one (the daemon cannot see processes;
  // `rs-discover clients` looks for the processes holding one).
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
  // disconnects are reconnected (options.reconnect()).
  Watch watch(WatchOptions options = {});
  // A live copy of the table (see DeviceView), following the devices that match
  // options.filter(). Returns once the stream is open and the view listed; throws at once
  // when the daemon cannot be reached then. options.initial() does not apply (no events).
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
