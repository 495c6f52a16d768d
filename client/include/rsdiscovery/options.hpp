// rsdiscovery/options.hpp: what a program tells the library (which devices, how to
// watch, how long to wait); part of <rsdiscovery/rsdiscovery.hpp>, which is what
// programs include.
//
// The three are opaque: each holds its settings behind a pointer and is set and read
// through member functions, so a setting added later changes neither their size nor
// the calls that take them, and programs built against librsdiscovery.so.1 keep
// working. Setters return the object, to chain:
//
//   client.list_devices(rsdiscovery::DeviceFilter().source("dds").in_use(false));
#pragma once

#include <rsdiscovery/types.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace rsdiscovery {

// Filters of GET /v1/devices and /v1/events. Nothing set: every device. The daemon
// applies them (values compare case-insensitively); the library never filters again.
class RSDISCOVERY_API DeviceFilter {
 public:
  DeviceFilter();
  DeviceFilter(const DeviceFilter&);
  DeviceFilter(DeviceFilter&&) noexcept;
  DeviceFilter& operator=(const DeviceFilter&);
  DeviceFilter& operator=(DeviceFilter&&) noexcept;
  ~DeviceFilter();

  // Devices on DDS domain `d`; called again, on any of the domains given.
  DeviceFilter& domain(int d);
  DeviceFilter& product_line(std::string line);  // "D400", "D500" ...
  DeviceFilter& source(std::string source);      // "dds", "usb" or "remote-usb" (another host's USB camera)
  DeviceFilter& serial(std::string serial);      // exactly this serial, ignoring case
  DeviceFilter& name(std::string text);          // a name containing this, ignoring case ("d455")
  // A camera whose server (or, remote-usb, whose host) has this address.
  DeviceFilter& address(std::string address);
  // The USB cameras the daemon on the host of this name shares (remote-usb; the name
  // as that host announces it, field "host" of the device document), ignoring case.
  DeviceFilter& host(std::string name);
  // true: only network cameras with a client now (their "in-use"); false: only those
  // without one, USB cameras included.
  DeviceFilter& in_use(bool used);

  const std::vector<int>& domains() const;  // empty: any
  const std::string& product_line() const;  // "": any (and so on)
  const std::string& source() const;
  const std::string& serial() const;
  const std::string& name() const;
  const std::string& address() const;
  const std::string& host() const;
  std::optional<bool> in_use() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct WatchStatus {  // connection state changes of a watch, for logging; never required
  bool connected = false;
  std::string message;  // why it disconnected, or where it connected
};

class RSDISCOVERY_API WatchOptions {
 public:
  WatchOptions();
  WatchOptions(const WatchOptions&);
  WatchOptions(WatchOptions&&) noexcept;
  WatchOptions& operator=(const WatchOptions&);
  WatchOptions& operator=(WatchOptions&&) noexcept;
  ~WatchOptions();

  // Report every device present when the watch starts as a synthetic `added`
  // (default false).
  WatchOptions& initial(bool report);
  // Resume after this event id (for example one saved by an earlier process).
  WatchOptions& last_event_id(std::uint64_t id);
  // Only devices that match are watched (the daemon filters the list and the stream).
  WatchOptions& filter(DeviceFilter filter);
  // Reconnect (and resume) when the daemon goes away, for example across a restart
  // (default true), waiting up to `max_reconnect_delay` between attempts (default 2 s).
  WatchOptions& reconnect(bool reconnect);
  WatchOptions& max_reconnect_delay(std::chrono::milliseconds delay);
  // A stream silent for this long is taken as dead and reconnected (default 60 s; the
  // daemon sends keep-alive comments well within it).
  WatchOptions& idle_timeout(std::chrono::milliseconds timeout);
  // After a daemon restart (a resync), the watch waits this long at most (default
  // 10 s) for the restarted daemon's first discovery to be over before it compares its
  // list with the view: so a camera that was there before and after the restart is not
  // reported removed and added again. 0: compare at once (cameras not heard from again
  // yet then show up as removed, and added a moment later). The first list is not
  // waited for: it is the starting point, and what arrives after it is reported as events.
  WatchOptions& complete_timeout(std::chrono::milliseconds timeout);
  // Told when the stream is lost and when it is back (pull-style watches too; the
  // push-style one takes its own on_status). Runs on the library's thread.
  WatchOptions& on_status(std::function<void(const WatchStatus&)> callback);

  bool initial() const;
  std::optional<std::uint64_t> last_event_id() const;
  const DeviceFilter& filter() const;
  bool reconnect() const;
  std::chrono::milliseconds max_reconnect_delay() const;
  std::chrono::milliseconds idle_timeout() const;
  std::chrono::milliseconds complete_timeout() const;
  const std::function<void(const WatchStatus&)>& on_status() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class RSDISCOVERY_API ClientOptions {
 public:
  ClientOptions();
  ClientOptions(const ClientOptions&);
  ClientOptions(ClientOptions&&) noexcept;
  ClientOptions& operator=(const ClientOptions&);
  ClientOptions& operator=(ClientOptions&&) noexcept;
  ~ClientOptions();

  ClientOptions& connect_timeout(std::chrono::milliseconds timeout);  // default 2 s
  ClientOptions& request_timeout(std::chrono::milliseconds timeout);  // default 10 s
  // list(), list_devices(), get_device(), find_device(), wait_for() and wait_until()
  // first wait this long at most (default 5 s) for the daemon to finish its first
  // discovery (it takes a few seconds after the daemon starts), so that a camera that
  // is there is never reported missing just because the daemon has not heard from it
  // yet. 0: answer at once from whatever the table holds.
  ClientOptions& complete_timeout(std::chrono::milliseconds timeout);
  // Called each time the daemon answers 503 with Retry-After (at its connection limit,
  // or making its DDS participant anew) and the library waits as told before asking
  // again, for up to 10 s in all: a sentence saying why and for how long, for a tool to
  // show its user. Runs on the calling thread; empty: wait silently.
  ClientOptions& on_busy(std::function<void(const std::string&)> callback);

  std::chrono::milliseconds connect_timeout() const;
  std::chrono::milliseconds request_timeout() const;
  std::chrono::milliseconds complete_timeout() const;
  const std::function<void(const std::string&)>& on_busy() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rsdiscovery
