// A reactor acting on its connections' decisions (HttpConnection::next): httplib
// serves a request (or the blocking pool does, parked), the answer goes out, event
// streams are pumped, and the sweep ticks the deadlines (reactor.hpp).
#include "api/reactor.hpp"

#include "log/log.hpp"

#include <algorithm>
#include <cerrno>

#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace rsd::api {

namespace {

std::uint32_t epoll_events(HttpConnection::Interest interest) {
  switch (interest) {
    case HttpConnection::Interest::none:
      return 0;
    case HttpConnection::Interest::read:
      return EPOLLIN | EPOLLRDHUP;
    case HttpConnection::Interest::write:
      return EPOLLOUT;
    case HttpConnection::Interest::read_write:
      return EPOLLIN | EPOLLRDHUP | EPOLLOUT;
  }
  return 0;
}

}  // namespace

void Reactor::on_connection(Connection& c, std::uint32_t events, Clock::time_point now) {
  switch (c.http.state()) {
    case HttpConnection::State::parked:
    case HttpConnection::State::closed:
      return;  // the blocking pool has it; errors show once it comes back
    case HttpConnection::State::reading:
      read_some(c, now);
      if (events & (EPOLLRDHUP | EPOLLHUP | EPOLLERR)) c.http.eof();
      break;
    case HttpConnection::State::writing:
      if (events & (EPOLLERR | EPOLLHUP)) c.http.error();
      else c.http.writable();
      break;
    case HttpConnection::State::streaming:
      if (events & (EPOLLIN | EPOLLRDHUP | EPOLLHUP | EPOLLERR)) read_some(c, now);  // eof: gone
      if (events & EPOLLOUT) c.http.writable();
      break;
  }
  drive(c, now);
}

bool Reactor::drive(Connection& c, Clock::time_point now) {
  for (;;) {
    const auto action = c.http.next(now);
    switch (action.kind) {
      case HttpConnection::Action::Kind::send: {
        const auto before = c.http.out().pending();
        send_pending(c);
        c.http.sent(now, c.http.out().pending() < before);
        continue;
      }
      case HttpConnection::Action::Kind::serve:
        c.http.served(serve(c), now);
        break;
      case HttpConnection::Action::Kind::park:
        if (park(c)) {
          set_interest(c, 0);
          return true;
        }
        c.http.park_refused(now);
        continue;
      case HttpConnection::Action::Kind::wait:
      case HttpConnection::Action::Kind::close:
        break;
    }
    if (action.kind == HttpConnection::Action::Kind::serve) {
      // The response became a stream (and the machine agreed): the loop feeds it.
      if (c.adopting && c.http.state() == HttpConnection::State::streaming) {
        c.feed = std::move(c.adopting);
        ++loop.streams;
      }
      c.adopting.reset();
      continue;
    }
    const auto counts = c.http.take_counts();
    loop.rejected += counts.rejected;
    loop.timed_out += counts.timed_out;
    loop.streams_dropped += counts.backlog_drops + counts.stall_drops;
    if (counts.backlog_drops > 0)
      log::info(std::string("api: dropped an event stream on ") + c.listener->name + ": " +
                std::to_string(c.http.out().pending()) + " bytes unread");
    if (action.kind == HttpConnection::Action::Kind::close) {
      close_connection(c);
      return false;
    }
    set_interest(c, epoll_events(action.interest));
    return true;
  }
}

HttpConnection::Served Reactor::serve(Connection& c) const {
  const bool stopping = loop.stopping.load();
  if (c.listener->quick) {
    QuickReply reply;
    if (c.listener->quick(std::string_view(c.http.in()).substr(0, c.http.request_length()), stopping, reply)) {
      Outbox& o = c.http.out();
      o.out.append(reply.head);
      if (reply.body && reply.body->fd() >= 0) {
        o.file = std::move(reply.body);
        o.file_offset = 0;
        o.file_left = o.file->bytes().size();
      } else if (reply.body) {
        o.out.append(reply.body->bytes());
      }
      return {c.http.request_length(), reply.close || stopping, false};
    }
  }
  RequestContext context;
  context.http = c.listener->http;
  set_request_context(&context);
  ConnectionStream stream(c);
  bool closed = false;
  const bool ok = c.listener->server->serve(stream, stopping, closed);
  set_request_context(nullptr);
  HttpConnection::Served result;
  result.consumed = stream.consumed();
  result.stream = context.adopt_as_stream != nullptr;
  result.close = !ok || closed || stopping;
  c.adopting = std::move(context.adopt_as_stream);
  return result;
}

bool Reactor::park(Connection& c) {
  if (loop.blocking.load() >= loop.options.max_blocking || loop.stopping.load()) return false;
  ++loop.blocking;
  loop.pool->enqueue([this, conn = &c] {
    conn->parked_result = serve(*conn);
    --loop.blocking;
    {
      std::lock_guard lock(returned_mutex);
      returned.push_back(conn);
    }
    wake();
  });
  return true;
}

void Reactor::take_returned(Clock::time_point now) {
  std::vector<Connection*> back;
  {
    std::lock_guard lock(returned_mutex);
    back.swap(returned);
  }
  for (auto* c : back) {
    if (!conns.contains(c)) continue;
    c->http.served(c->parked_result, now);
    drive(*c, now);
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
  c.http.stream_text(text, now);
  drive(c, now);
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
    c->http.tick(now);
    if (!drive(*c, now)) continue;
    if (c->http.state() == HttpConnection::State::streaming && c->feed) pump(*c, now);  // keep-alives
  }
}

ServerLoop::ServerLoop(LoopOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}

ServerLoop::~ServerLoop() { stop(std::chrono::milliseconds(0)); }

}  // namespace rsd::api
