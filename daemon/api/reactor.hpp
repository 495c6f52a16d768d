// The API's event loops: ServerLoop's shared state (Impl) and one Reactor per
// loop thread, with its epoll and its connections. The reactor does the I/O and
// feeds each connection's HttpConnection, which decides (reactor.cpp: accepting,
// reading, stopping; reactor_requests.cpp: acting on the decisions: serving,
// parking on the blocking pool, streaming, ticks). Internal to daemon/api.
#pragma once

#include "api/connection.hpp"

#include <atomic>
#include <memory>
#include <mutex>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#include <sys/epoll.h>
#include <unistd.h>

namespace rsd::api {

struct Reactor;

struct ServerLoop::Impl {
  LoopOptions options;
  ConnectionOptions connection;  // what each connection's HttpConnection reads, from `options`
  std::vector<LoopListener> listeners;
  std::vector<std::unique_ptr<Reactor>> reactors;
  std::unique_ptr<BlockingPool> pool;
  std::mutex lifecycle;
  bool started = false;

  std::atomic<bool> stopping{false};
  std::atomic<Clock::rep> stop_deadline{0};
  std::atomic<std::size_t> connections{0};
  // Held from accept4 to counting what was accepted. Both reactors take from the same
  // listeners; without it one could count its accept after the other had already judged a
  // later client against the lower number, letting a client in past max_connections.
  std::mutex accepting;
  std::atomic<std::size_t> streams{0};
  std::atomic<std::size_t> blocking{0};
  std::atomic<std::uint64_t> refused{0};
  std::atomic<std::uint64_t> timed_out{0};
  std::atomic<std::uint64_t> streams_dropped{0};
  std::atomic<std::uint64_t> rejected{0};

  explicit Impl(LoopOptions o) : options(std::move(o)) {
    connection.head = options.head;
    connection.client_timeout = options.client_timeout;
    connection.idle_timeout = options.idle_timeout;
    connection.stream_buffer_limit = options.stream_buffer_limit;
    connection.blocking = options.blocking;
  }
  // Gives `fd`, accepted for `listener` and counted in `connections`, to the loop
  // with the fewest; `self` (the accepting loop, or none) takes it when that one has ended.
  void hand_out(int fd, const LoopListener& listener, Reactor* self, Clock::time_point now);
};

// One event loop: its own epoll, the connections it accepted, one thread.
struct Reactor {
  explicit Reactor(ServerLoop::Impl& l) : loop(l) {}
  ~Reactor() {
    for (auto& [_, c] : conns) ::close(c->fd);
    for (auto& [fd, _] : handed) ::close(fd);
    if (epfd >= 0) ::close(epfd);
    if (wake_fd >= 0) ::close(wake_fd);
  }

  ServerLoop::Impl& loop;
  int epfd = -1;
  int wake_fd = -1;
  Pollable wake_handle{Pollable::Kind::wake};
  std::vector<std::unique_ptr<ListenerHandle>> listeners;
  std::unordered_map<Connection*, std::unique_ptr<Connection>> conns;
  std::mutex returned_mutex;
  std::vector<Connection*> returned;  // back from the blocking pool
  // Connections this loop owns, or has been handed and not yet taken: new ones go
  // to the loop with the fewest. One loop often wakes for a whole burst of clients
  // (EPOLLEXCLUSIVE wakes one), and keeping them all left the other core idle: the
  // benchmark's throughput then doubled or halved by that luck alone.
  std::atomic<std::size_t> owned{0};
  std::mutex handed_mutex;
  std::vector<std::pair<int, const LoopListener*>> handed;  // accepted by another loop, for this one
  bool handed_closed = false;  // under handed_mutex: this loop has ended, serve your own
  std::atomic<bool> table_changed{false};
  bool stop_begun = false;
  std::thread thread;

  void wake() {
    const std::uint64_t one = 1;
    [[maybe_unused]] auto n = ::write(wake_fd, &one, sizeof one);
  }

  void set_interest(Connection& c, std::uint32_t events) {
    if (c.interest == events) return;
    epoll_event ev{};
    ev.events = events;
    ev.data.ptr = static_cast<Pollable*>(&c);
    epoll_ctl(epfd, EPOLL_CTL_MOD, c.fd, &ev);
    c.interest = events;
  }

  void close_connection(Connection& c) {
    epoll_ctl(epfd, EPOLL_CTL_DEL, c.fd, nullptr);
    ::close(c.fd);
    --loop.connections;
    --owned;
    if (c.feed) --loop.streams;
    conns.erase(&c);  // destroys c
  }

  // At the loop's end: no connection may be handed to it any more. false if one
  // came meanwhile (taken now, to be answered first).
  bool close_handed() {
    std::lock_guard lock(handed_mutex);
    if (!handed.empty()) return false;
    handed_closed = true;
    return true;
  }
  void run();
  void begin_stop(Clock::time_point now);
  void accept_all(ListenerHandle& l, Clock::time_point now);
  // Takes a connection accepted for this loop (counted in `owned` already).
  void adopt(int fd, const LoopListener& listener, Clock::time_point now);
  // From another thread: a connection for this loop (counted in `owned` already).
  // false: this loop has ended.
  bool give(int fd, const LoopListener& listener);
  void take_handed(Clock::time_point now);
  void on_connection(Connection& c, std::uint32_t events, Clock::time_point now);
  // Reads what the socket has into the connection's machine.
  void read_some(Connection& c, Clock::time_point now);
  // Does what the connection's machine asks until it waits; false: it was closed.
  bool drive(Connection& c, Clock::time_point now);
  HttpConnection::Served serve(Connection& c) const;
  bool park(Connection& c);
  void take_returned(Clock::time_point now);
  void pump(Connection& c, Clock::time_point now);
  void sweep(Clock::time_point now);
};

}  // namespace rsd::api
