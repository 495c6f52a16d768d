// The API connection machine's test double for the reactor: it does what
// HttpConnection::next asks with a stubbed socket (that takes `room` bytes a send)
// and a stubbed httplib (that answers "GET /x" with the body "/x", and a broken
// request line with a 400), on a clock the test moves. The wire is what the
// client got, parsed back into responses.
#pragma once

#include "api/http_connection.hpp"

#include <gtest/gtest.h>

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace rsd::api::test {

using namespace std::chrono_literals;
using Kind = HttpConnection::Action::Kind;
using State = HttpConnection::State;

inline std::string get(const std::string& target, const std::string& extra = "") {
  return "GET " + target + " HTTP/1.1\r\nHost: localhost\r\n" + extra + "\r\n";
}

struct Response {
  int status = 0;
  std::string body;
  bool close = false;  // said "Connection: close"
};

// Splits `wire` into the responses it holds; `rest` gets what is left over (a
// response not all there yet).
inline std::vector<Response> parse(const std::string& wire, std::string* rest = nullptr) {
  std::vector<Response> out;
  std::size_t pos = 0;
  for (;;) {
    const auto end = wire.find("\r\n\r\n", pos);
    if (end == std::string::npos) break;
    const std::string head = wire.substr(pos, end - pos);
    const auto cl = head.find("Content-Length: ");
    if (head.rfind("HTTP/1.1 ", 0) != 0 || cl == std::string::npos) break;
    const auto length = std::stoul(head.substr(cl + 16));
    if (wire.size() < end + 4 + length) break;
    Response r;
    r.status = std::stoi(head.substr(9, 3));
    r.close = head.find("Connection: close") != std::string::npos;
    r.body = wire.substr(end + 4, length);
    out.push_back(r);
    pos = end + 4 + length;
  }
  if (rest) *rest = wire.substr(pos);
  return out;
}

struct Driver {
  ConnectionOptions options;
  Clock::time_point now = Clock::time_point{} + 1000h;
  std::unique_ptr<HttpConnection> m;
  std::string wire;                                          // what the client received
  std::size_t room = std::numeric_limits<std::size_t>::max();  // what the socket takes per send
  std::vector<std::string> served;                           // targets httplib saw, in order
  bool parked = false;                                       // a request is on the blocking pool
  std::string parked_target;
  bool closed = false;
  HttpConnection::Interest interest = HttpConnection::Interest::read;
  HttpConnection::Counts counts;
  bool stream_targets = true;  // "/events..." becomes an SSE stream
  bool close_targets = true;   // "/close..." makes httplib ask for a close

  Driver() { options.head.max_head = 1024; options.head.max_request_line = 512; options.head.max_body = 64; }
  void open(bool stopping = false) { m = std::make_unique<HttpConnection>(options, now, stopping); }

  // httplib's part: the request's target as the body.
  HttpConnection::Served respond() {
    const std::string request = m->in().substr(0, m->request_length());
    const auto a = request.find(' ');
    const std::string target = request.substr(a + 1, request.find(' ', a + 1) - a - 1);
    HttpConnection::Served r;
    // httplib reads the head; a body (of a GET) it leaves unread, as it may.
    r.consumed = request.find("\r\n\r\n") + 4;
    if (request.rfind("GET /", 0) != 0) {  // what httplib makes of a broken request line
      served.push_back("<bad>");
      m->out().out += canned_response(400, "bad request", false);
      r.close = true;
      return r;
    }
    served.push_back(target);
    if (stream_targets && target.rfind("/events", 0) == 0) {
      m->out().out += "HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n" + chunk("retry: 1000\n\n");
      r.stream = true;
      return r;
    }
    r.close = close_targets && target.rfind("/close", 0) == 0;
    m->out().out += "HTTP/1.1 200 OK\r\n" + std::string(r.close ? "Connection: close\r\n" : "") +
                    "Content-Length: " + std::to_string(target.size()) + "\r\n\r\n" + target;
    return r;
  }

  // Does what the machine asks until it waits.
  void run() {
    for (int guard = 0; guard < 1000; ++guard) {
      const auto a = m->next(now);
      auto c = m->take_counts();
      counts.rejected += c.rejected;
      counts.timed_out += c.timed_out;
      counts.backlog_drops += c.backlog_drops;
      counts.stall_drops += c.stall_drops;
      switch (a.kind) {
        case Kind::send: {
          ASSERT_FALSE(closed);
          auto& o = m->out();
          const auto n = std::min(room, o.out_pending());
          wire.append(o.out, o.out_pos, n);
          o.out_pos += n;
          if (o.out_pending() == 0) {
            o.out.clear();
            o.out_pos = 0;
          }
          m->sent(now, n > 0);
          break;
        }
        case Kind::serve:
          ASSERT_FALSE(parked) << "served while a request was parked";
          m->served(respond(), now);
          break;
        case Kind::park: {
          ASSERT_FALSE(parked) << "two requests parked at once";
          parked = true;
          const std::string request = m->in().substr(0, m->request_length());
          parked_target = request.substr(4, request.find(' ', 4) - 4);
          interest = a.interest;
          return;
        }
        case Kind::wait:
          interest = a.interest;
          return;
        case Kind::close:
          closed = true;
          return;
      }
    }
    FAIL() << "the machine never waited";
  }

  // The blocking pool finished the parked request.
  void unpark() {
    ASSERT_TRUE(parked);
    parked = false;
    m->served(respond(), now);
    run();
  }
  void feed(const std::string& bytes) {
    m->bytes(bytes, now);
    run();
  }
  void writable() {
    m->writable();
    run();
  }
  void tick(std::chrono::milliseconds after) {
    now += after;
    m->tick(now);
    run();
  }
  std::vector<Response> responses(std::string* rest = nullptr) const { return parse(wire, rest); }
};

}  // namespace rsd::api::test
