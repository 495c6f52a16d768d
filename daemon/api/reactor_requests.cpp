// A reactor's connections once a request is in: httplib serves it (or the
// blocking pool does, parked), the answer goes out, event streams are pumped, and
// the sweep enforces timeouts (reactor.hpp).
#include "api/reactor.hpp"

#include "api/connection_stream.hpp"
#include "log/log.hpp"

#include <algorithm>
#include <cerrno>

#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace rsd::api {

void Reactor::on_connection(Connection& c, std::uint32_t events, Clock::time_point now) {
  switch (c.state) {
    case ConnState::parked:
      return;  // the blocking pool has it; errors show once it comes back
    case ConnState::reading: {
      bool eof = false, error = false;
      read_some(c, eof, error);
      if (error) return close_connection(c);
      return process_input(c, eof || (events & (EPOLLRDHUP | EPOLLHUP | EPOLLERR)), now);
    }
    case ConnState::writing:
      if ((events & (EPOLLERR | EPOLLHUP)) || !send_pending(c, now)) return close_connection(c);
      if (c.pending() > 0) return;
      if (c.close_after_write) return close_connection(c);
      c.state = ConnState::reading;
      c.deadline = now + (c.in.empty() ? loop.options.idle_timeout : loop.options.client_timeout);
      set_interest(c, EPOLLIN | EPOLLRDHUP);
      return process_input(c, false, now);
    case ConnState::streaming: {
      if (events & (EPOLLIN | EPOLLRDHUP | EPOLLHUP | EPOLLERR)) {
        bool eof = false, error = false;
        read_some(c, eof, error);
        if (eof || error) return close_connection(c);  // the client went away
      }
      if ((events & EPOLLOUT) && !send_pending(c, now)) return close_connection(c);
      set_interest(c, EPOLLIN | EPOLLRDHUP | (c.pending() > 0 ? EPOLLOUT : 0u));
      return;
    }
  }
}

void Reactor::process_input(Connection& c, bool eof, Clock::time_point now) {
  while (c.state == ConnState::reading) {
    if (c.in.empty()) {
      if (eof) close_connection(c);
      return;
    }
    const auto scan = scan_request_head(c.in, loop.options.head, c.scanned);
    const auto& limits = loop.options.head;
    switch (scan.verdict) {
      case HeadVerdict::incomplete:
        c.scanned = scan.scanned;
        if (eof) close_connection(c);
        return;
      case HeadVerdict::uri_too_long:
        return reject(c, 414, "request line longer than " + std::to_string(limits.max_request_line) + " bytes", now);
      case HeadVerdict::head_too_large:
        return reject(c, 431, "request header section larger than " + std::to_string(limits.max_head) + " bytes", now);
      case HeadVerdict::body_too_large:
        return reject(c, 413, "request body larger than " + std::to_string(limits.max_body) + " bytes", now);
      case HeadVerdict::bad_request:
        return reject(c, 400, "bad Content-Length", now);
      case HeadVerdict::complete:
        break;
    }
    c.scanned = 0;
    c.request_length = scan.head_length + scan.body_length;
    if (c.in.size() < c.request_length) {  // the body is on its way
      if (eof) close_connection(c);
      return;
    }
    if (eof) c.close_after_write = true;  // answer, then close: the client is done sending
    if (loop.options.blocking && loop.options.blocking(scan.target)) return park(c, now);
    serve(c);
    if (!after_serve(c, now)) return;
  }
}

void Reactor::reject(Connection& c, int status, const std::string& message, Clock::time_point now) {
  ++loop.rejected;
  c.in.clear();
  c.out += canned_response(status, message, false);
  c.close_after_write = true;
  c.state = ConnState::writing;
  c.last_progress = now;
  if (!send_pending(c, now) || c.pending() == 0) return close_connection(c);
  set_interest(c, EPOLLOUT);
}

void Reactor::serve(Connection& c) const {
  RequestContext context;
  context.http = c.listener->http;
  set_request_context(&context);
  ConnectionStream stream(c);
  bool closed = false;
  const bool ok = c.listener->server->serve(stream, loop.stopping.load(), closed);
  set_request_context(nullptr);
  // A body httplib did not read (a GET with one) must not be taken for the next request.
  c.in.erase(0, std::min(c.in.size(), std::max(stream.consumed(), c.request_length)));
  if (context.adopt_as_stream && !c.broken) {
    c.feed = std::move(context.adopt_as_stream);
    c.state = ConnState::streaming;
    ++loop.streams;
    return;
  }
  if (!ok || closed || loop.stopping.load()) c.close_after_write = true;
}

// Sends the response `serve` left; true when the connection is reading again and
// a pipelined request may follow.
bool Reactor::after_serve(Connection& c, Clock::time_point now) {
  c.last_progress = now;
  ++c.served;
  if (c.state == ConnState::streaming) {
    if (!send_pending(c, now)) {
      close_connection(c);
      return false;
    }
    set_interest(c, EPOLLIN | EPOLLRDHUP | (c.pending() > 0 ? EPOLLOUT : 0u));
    return false;
  }
  if (c.broken || !send_pending(c, now)) {
    close_connection(c);
    return false;
  }
  if (c.pending() > 0) {
    c.state = ConnState::writing;
    set_interest(c, EPOLLOUT);
    return false;
  }
  if (c.close_after_write) {
    close_connection(c);
    return false;
  }
  c.state = ConnState::reading;
  c.deadline = now + (c.in.empty() ? loop.options.idle_timeout : loop.options.client_timeout);
  set_interest(c, EPOLLIN | EPOLLRDHUP);
  return true;
}

void Reactor::park(Connection& c, Clock::time_point now) {
  if (loop.blocking.load() >= loop.options.max_blocking || loop.stopping.load()) {
    auto reply = canned_response(503, "too many requests waiting for a camera; retry later", true);
    c.in.erase(0, std::min(c.in.size(), c.request_length));
    c.out += reply;
    c.close_after_write = true;
    c.state = ConnState::writing;
    if (!send_pending(c, now) || c.pending() == 0) return close_connection(c);
    return set_interest(c, EPOLLOUT);
  }
  ++loop.blocking;
  c.state = ConnState::parked;
  set_interest(c, 0);
  loop.pool->enqueue([this, conn = &c] {
    serve(*conn);
    --loop.blocking;
    {
      std::lock_guard lock(returned_mutex);
      returned.push_back(conn);
    }
    wake();
  });
}

void Reactor::take_returned(Clock::time_point now) {
  std::vector<Connection*> back;
  {
    std::lock_guard lock(returned_mutex);
    back.swap(returned);
  }
  for (auto* c : back) {
    if (!conns.contains(c)) continue;
    if (c->state == ConnState::parked) c->state = ConnState::reading;
    if (stop_begun) c->close_after_write = true;
    if (after_serve(*c, now)) process_input(*c, false, now);
  }
}

void Reactor::pump(Connection& c, Clock::time_point now) {
  std::string text;
  try {
    text = c.feed->poll(now);
  } catch (const std::exception& e) {
    log::error(std::string("api: event stream failed: ") + e.what());
    return close_connection(c);
  }
  if (!text.empty()) {
    if (c.pending() == 0) c.last_progress = now;
    c.out += chunk(text);
  }
  if (c.pending() > loop.options.stream_buffer_limit) {
    // It stopped reading: letting its backlog grow would let one client take
    // the daemon's memory. It reconnects with Last-Event-ID and resumes.
    ++loop.streams_dropped;
    log::info(std::string("api: dropped an event stream on ") + c.listener->name + ": " +
              std::to_string(c.pending()) + " bytes unread");
    return close_connection(c);
  }
  if (!send_pending(c, now)) return close_connection(c);
  set_interest(c, EPOLLIN | EPOLLRDHUP | (c.pending() > 0 ? EPOLLOUT : 0u));
}

void Reactor::sweep(Clock::time_point now) {
  for (auto& l : listeners) {
    if (!l->paused || now < l->resume_at || stop_begun) continue;
    epoll_event ev{};
    ev.events = EPOLLIN | EPOLLEXCLUSIVE;
    ev.data.ptr = static_cast<Pollable*>(l.get());
    if (epoll_ctl(epfd, EPOLL_CTL_ADD, l->spec->fd, &ev) == 0) l->paused = false;
  }
  std::vector<Connection*> all;
  all.reserve(conns.size());
  for (auto& [p, _] : conns) all.push_back(p);
  for (auto* c : all) {
    switch (c->state) {
      case ConnState::reading:
        if (now < c->deadline) break;
        if (c->in.empty()) {
          close_connection(*c);  // idle: nothing to say
        } else {
          ++loop.timed_out;
          reject(*c, 408, "request not complete within " +
                              std::to_string(loop.options.client_timeout.count()) + " ms", now);
        }
        break;
      case ConnState::writing:
        if (now - c->last_progress >= loop.options.client_timeout) {
          ++loop.timed_out;
          close_connection(*c);
        }
        break;
      case ConnState::streaming:
        if (c->pending() > 0 && now - c->last_progress >= kStreamStall) {
          ++loop.streams_dropped;
          close_connection(*c);
          break;
        }
        pump(*c, now);  // keep-alives
        break;
      case ConnState::parked:
        break;
    }
  }
}

ServerLoop::ServerLoop(LoopOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}

ServerLoop::~ServerLoop() { stop(std::chrono::milliseconds(0)); }

}  // namespace rsd::api
