// ServerLoop: the API's event loops started on the listeners (one reactor a
// thread, reactor.hpp), woken on table changes, stopped with a grace, counted.
#include "api/server_loop.hpp"

#include "api/reactor.hpp"

#include <algorithm>

#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/resource.h>
#include <unistd.h>

namespace rsd::api {

int loop_threads_for(int cpus) { return std::clamp(cpus / 2, 1, 2); }

void ServerLoop::start(std::vector<LoopListener> listeners) {
  std::lock_guard lock(impl_->lifecycle);
  if (impl_->started) throw std::runtime_error("server loop already started");
  auto& o = impl_->options;
  o.threads = std::max(1, o.threads);
  impl_->listeners = std::move(listeners);
  for (auto& l : impl_->listeners) {
    if (l.fd < 0) continue;
    const int flags = fcntl(l.fd, F_GETFL);
    fcntl(l.fd, F_SETFL, flags | O_NONBLOCK);
  }
  // Every client is a file descriptor: the soft limit (often 1,024) must not be
  // what refuses them before max_connections does.
  rlimit rl{};
  if (getrlimit(RLIMIT_NOFILE, &rl) == 0) {
    const rlim_t want = std::min<rlim_t>(rl.rlim_max, static_cast<rlim_t>(o.max_connections) + 1024);
    if (rl.rlim_cur < want) {
      rl.rlim_cur = want;
      setrlimit(RLIMIT_NOFILE, &rl);
    }
  }
  impl_->pool = std::make_unique<BlockingPool>(static_cast<std::size_t>(std::max(1, o.blocking_threads)));
  try {
    make_reactors();
  } catch (...) {
    // Not started: the pool's threads would otherwise outlive it (the daemon hung
    // on its way out after a listener epoll refused).
    impl_->reactors.clear();
    impl_->pool->shutdown();
    impl_->pool.reset();
    throw;
  }
  for (auto& r : impl_->reactors) r->thread = std::thread([raw = r.get()] { raw->run(); });
  impl_->started = true;
}

void ServerLoop::make_reactors() {
  const auto& o = impl_->options;
  for (int i = 0; i < o.threads; ++i) {
    auto r = std::make_unique<Reactor>(*impl_);
    r->epfd = epoll_create1(EPOLL_CLOEXEC);
    r->wake_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (r->epfd < 0 || r->wake_fd < 0) throw std::runtime_error(std::string("api: epoll: ") + std::strerror(errno));
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.ptr = &r->wake_handle;
    epoll_ctl(r->epfd, EPOLL_CTL_ADD, r->wake_fd, &ev);
    for (const auto& l : impl_->listeners) {
      if (l.fd < 0) continue;
      auto h = std::make_unique<ListenerHandle>(l);
      // EXCLUSIVE: a new client wakes one loop, not all of them.
      epoll_event lev{};
      lev.events = EPOLLIN | EPOLLEXCLUSIVE;
      lev.data.ptr = static_cast<Pollable*>(h.get());
      if (epoll_ctl(r->epfd, EPOLL_CTL_ADD, l.fd, &lev) != 0)
        throw std::runtime_error("api: cannot watch " + l.name + ": " + std::strerror(errno));
      r->listeners.push_back(std::move(h));
    }
    impl_->reactors.push_back(std::move(r));
  }
}

void ServerLoop::adopt(int fd, std::size_t listener) {
  std::lock_guard lock(impl_->lifecycle);
  if (!impl_->started || listener >= impl_->listeners.size() || impl_->stopping.load()) {
    ::close(fd);
    return;
  }
  const int flags = fcntl(fd, F_GETFL);
  fcntl(fd, F_SETFL, flags | O_NONBLOCK);
  ++impl_->connections;
  impl_->hand_out(fd, impl_->listeners[listener], nullptr, Clock::now());
}

void ServerLoop::notify_change() {
  for (auto& r : impl_->reactors) {
    r->table_changed = true;
    r->wake();
  }
}

void ServerLoop::stop(std::chrono::milliseconds grace) {
  std::lock_guard lock(impl_->lifecycle);
  if (!impl_->started) return;
  impl_->stop_deadline = (Clock::now() + grace).time_since_epoch().count();
  impl_->stopping = true;
  for (auto& r : impl_->reactors) r->wake();
  for (auto& r : impl_->reactors)
    if (r->thread.joinable()) r->thread.join();
  // Requests on the blocking pool finish (bounded by the describe timeout);
  // their connections are closed with the reactors.
  impl_->pool->shutdown();
  impl_->reactors.clear();
  impl_->pool.reset();
  impl_->started = false;
}

LoopStats ServerLoop::stats() const {
  LoopStats s;
  s.connections = impl_->connections.load();
  s.streams = impl_->streams.load();
  s.refused = impl_->refused.load();
  s.timed_out = impl_->timed_out.load();
  s.streams_dropped = impl_->streams_dropped.load();
  s.rejected = impl_->rejected.load();
  return s;
}

}  // namespace rsd::api
