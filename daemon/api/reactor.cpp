// A reactor's loop: accepting (balanced between the loops), reading, and the
// stop that answers every connection accepted (reactor.hpp).
#include "api/reactor.hpp"

#include "log/log.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>

#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace rsd::api {

void Reactor::run() {
  std::array<epoll_event, 128> events{};
  auto next_sweep = Clock::now() + kSweepEvery;
  for (;;) {
    auto now = Clock::now();
    if (loop.stopping.load() && !stop_begun) begin_stop(now);
    if (stop_begun) {
      sweep(now);  // the connections given kFirstRequestWait
      const bool parked = std::any_of(conns.begin(), conns.end(),
                                      [](const auto& kv) { return kv.second->http.state() == HttpConnection::State::parked; });
      const bool over = now.time_since_epoch().count() >= loop.stop_deadline.load();
      if ((conns.empty() || (over && !parked)) && close_handed()) break;
      if (over) {  // what is left (but for parked requests) is cut
        std::vector<Connection*> cut;
        for (auto& [p, c] : conns)
          if (c->http.state() != HttpConnection::State::parked) cut.push_back(p);
        for (auto* c : cut) close_connection(*c);
      }
    }
    int timeout = -1;
    if (stop_begun) {
      timeout = 10;
    } else if (!conns.empty() || std::any_of(listeners.begin(), listeners.end(), [](auto& l) { return l->paused; })) {
      timeout = static_cast<int>(std::max<std::int64_t>(
          0, std::chrono::ceil<std::chrono::milliseconds>(next_sweep - now).count()));
    }
    const int n = epoll_wait(epfd, events.data(), static_cast<int>(events.size()), timeout);
    now = Clock::now();
    for (int i = 0; i < n; ++i) {
      auto* p = static_cast<Pollable*>(events[i].data.ptr);
      // A connection closed earlier in this batch (a pump, a sweep) is freed and
      // may still have an entry here: it is looked up before it is read.
      const bool known = p == &wake_handle ||
                         std::any_of(listeners.begin(), listeners.end(), [&](const auto& l) { return l.get() == p; }) ||
                         conns.contains(static_cast<Connection*>(p));
      if (!known) continue;
      switch (p->kind) {
        case Pollable::Kind::listener:
          accept_all(*static_cast<ListenerHandle*>(p), now);
          break;
        case Pollable::Kind::wake: {
          std::uint64_t v;
          [[maybe_unused]] auto r = ::read(wake_fd, &v, sizeof v);
          take_handed(now);
          take_returned(now);
          if (table_changed.exchange(false)) {
            // pump() may close (and so erase) a connection: not while iterating.
            std::vector<Connection*> streams;
            for (auto& [key, c] : conns)
              if (c->http.state() == HttpConnection::State::streaming) streams.push_back(key);
            for (auto* c : streams) pump(*c, now);
          }
          break;
        }
        case Pollable::Kind::connection: {
          on_connection(*static_cast<Connection*>(p), events[i].events, now);
          break;
        }
      }
    }
    if (now >= next_sweep) {
      sweep(now);
      next_sweep = now + kSweepEvery;
    }
  }
}

void Reactor::begin_stop(Clock::time_point now) {
  stop_begun = true;
  for (auto& l : listeners) epoll_ctl(epfd, EPOLL_CTL_DEL, l->spec->fd, nullptr);
  std::vector<Connection*> all;
  for (auto& [p, _] : conns) all.push_back(p);
  for (auto* c : all) {
    // What a reading connection's client sent already counts: its request is answered.
    if (c->http.state() == HttpConnection::State::reading) read_some(*c, now);
    c->http.stop(now);
    drive(*c, now);
  }
}

void Reactor::accept_all(ListenerHandle& l, Clock::time_point now) {
  for (;;) {
    // Stopping: what is still queued waits in the listener for the next daemon
    // (systemd keeps the socket), rather than being accepted and cut.
    if (loop.stopping.load()) return;
    std::unique_lock accepting(loop.accepting);
    const int fd = ::accept4(l.spec->fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
        // Level-triggered, the listener would wake us at once again: pause it.
        log::warning(std::string("api: cannot accept on ") + l.spec->name + ": " + std::strerror(errno) +
                     "; pausing " + std::to_string(kAcceptPause.count()) + " ms");
        epoll_ctl(epfd, EPOLL_CTL_DEL, l.spec->fd, nullptr);
        l.paused = true;
        l.resume_at = now + kAcceptPause;
      }
      return;
    }
    if (loop.connections.load() >= loop.options.max_connections) {
      accepting.unlock();
      // Full: say so at once (the client retries) rather than leave it hanging.
      const auto reply = canned_response(
          503, "too many clients (limit " + std::to_string(loop.options.max_connections) + "); retry later", true);
      [[maybe_unused]] auto n = ::send(fd, reply.data(), reply.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      ::close(fd);
      ++loop.refused;
      continue;
    }
    ++loop.connections;
    accepting.unlock();
    loop.hand_out(fd, *l.spec, this, now);
  }
}

void ServerLoop::Impl::hand_out(int fd, const LoopListener& listener, Reactor* self, Clock::time_point now) {
  Reactor* target = self ? self : reactors.front().get();
  for (auto& r : reactors)
    if (r->owned.load() < target->owned.load()) target = r.get();
  ++target->owned;
  if (target == self) return self->adopt(fd, listener, now);
  if (target->give(fd, listener)) return;
  --target->owned;
  if (self) {  // that loop has ended (stopping): this one answers it
    ++self->owned;
    return self->adopt(fd, listener, now);
  }
  ::close(fd);  // every loop has ended
  --connections;
}

bool Reactor::give(int fd, const LoopListener& listener) {
  {
    std::lock_guard lock(handed_mutex);
    if (handed_closed) return false;
    handed.emplace_back(fd, &listener);
  }
  wake();
  return true;
}

void Reactor::adopt(int fd, const LoopListener& listener, Clock::time_point now) {
  // Accepted by a loop not yet stopping, handed to this one: served all the same
  // (its client has no other daemon to ask), then closed.
  auto conn = std::make_unique<Connection>(fd, listener, loop.connection, now, stop_begun);
  conn->interest = EPOLLIN | EPOLLRDHUP;
  epoll_event ev{};
  ev.events = conn->interest;
  ev.data.ptr = static_cast<Pollable*>(conn.get());
  if (epoll_ctl(epfd, EPOLL_CTL_ADD, fd, &ev) != 0) {
    ::close(fd);
    --loop.connections;
    --owned;
    return;
  }
  Connection* raw = conn.get();
  conns.emplace(raw, std::move(conn));
}

void Reactor::take_handed(Clock::time_point now) {
  std::vector<std::pair<int, const LoopListener*>> mine;
  {
    std::lock_guard lock(handed_mutex);
    mine.swap(handed);
  }
  for (auto& [fd, listener] : mine) adopt(fd, *listener, now);
}

void Reactor::read_some(Connection& c, Clock::time_point now) {
  // Enough for the largest request the limits allow, and a little: beyond it the
  // scan has its verdict and the rest need not be read.
  const auto cap = loop.options.head.max_head + loop.options.head.max_body + kReadChunk;
  char buf[kReadChunk];
  for (;;) {
    const ssize_t n = ::recv(c.fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n > 0) {
      c.http.bytes(std::string_view(buf, static_cast<std::size_t>(n)), now);
      // Less than asked for: the socket is drained for now, and the level-triggered
      // epoll says when more comes. Asking again only to hear EAGAIN was a second
      // system call for every request (nginx stops at a short read too).
      if (c.http.in().size() >= cap || static_cast<std::size_t>(n) < sizeof buf) return;
      continue;
    }
    if (n == 0) return c.http.eof();
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) c.http.error();
    return;
  }
}

}  // namespace rsd::api
