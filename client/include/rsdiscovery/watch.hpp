// rsdiscovery/watch.hpp: following the daemon's table (Watch, DeviceView, Subscription);
// part of <rsdiscovery/rsdiscovery.hpp>, which is what programs include.
#pragma once

#include <rsdiscovery/options.hpp>
#include <rsdiscovery/types.hpp>

#include <chrono>
#include <cstdint>
#include <exception>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace rsdiscovery {

// ---------------------------------------------------------------------------------
// Watching

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

}  // namespace rsdiscovery
