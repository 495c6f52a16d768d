// A connection of the API's event loops as its three users see it: the reactor
// (reactor.hpp), the send path (send_path.cpp) and httplib's stream over it
// (httplib_seam.cpp); its decisions are its HttpConnection's. Internal to
// daemon/api.
#pragma once

#include "api/http_connection.hpp"
#include "api/server_loop.hpp"

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace rsd::api {

// How often timeouts and stream keep-alives are looked at: timeouts need no
// finer grain, and an idle daemon with no client never wakes for it.
constexpr auto kSweepEvery = std::chrono::milliseconds(250);
// A write this large goes to the socket at once instead of being copied behind
// the headers (a device list is tens of kilobytes).
constexpr std::size_t kDirectWrite = 16 * 1024;
constexpr std::size_t kReadChunk = 16 * 1024;
// After running out of file descriptors, accepting waits this long.
constexpr auto kAcceptPause = std::chrono::milliseconds(100);

struct Pollable {
  enum class Kind { listener, wake, connection };
  explicit Pollable(Kind k) : kind(k) {}
  const Kind kind;
};

struct ListenerHandle : Pollable {
  explicit ListenerHandle(const LoopListener& s) : Pollable(Kind::listener), spec(&s) {}
  const LoopListener* spec;
  bool paused = false;
  Clock::time_point resume_at{};
};

struct Connection : Pollable {
  Connection(int f, const LoopListener& l, const ConnectionOptions& options, Clock::time_point now, bool stopping)
      : Pollable(Kind::connection), fd(f), listener(&l), http(options, now, stopping) {}
  const int fd;
  const LoopListener* const listener;
  HttpConnection http;  // every decision; this struct and the reactor only do the I/O
  std::shared_ptr<EventFeed> feed;
  // Set while a request is served: the feed its response became, and (on the
  // blocking pool) what serving did, for the loop to take when it comes back.
  std::shared_ptr<EventFeed> adopting;
  HttpConnection::Served parked_result;
  std::uint32_t interest = 0;
  // Both ends' addresses, asked of the kernel once: httplib wants them for every
  // request, and two system calls a request showed in the profile.
  struct Address {
    bool known = false;
    std::string ip;
    int port = 0;
  };
  Address local, remote;
};

// Sends what `c` has pending, without blocking: its bytes, then the body from its
// memfd (through this thread's splice pipe on a Unix socket), until the socket is
// full or the turn's bytes are out. false: the connection is dead (and `broken` set).
bool send_pending(Connection& c);

// A turn's bytes. A reader as fast as the loop never makes its socket say EAGAIN:
// without an end to the turn, a large body (a list of thousands of cameras) went
// out whole while the loop's other connections waited, and their requests made the
// tail. What is left waits for the next EPOLLOUT (level-triggered, so at once),
// after the others' turns. Smaller turns cost more loop turns than they save; larger
// ones bring the tail back (bench/ scale10k).
constexpr std::size_t kSendTurnBytes = 256 * 1024;

// httplib's request context of the request being served on this thread (set by
// the reactor around httplib's processing; httplib_seam.cpp).
void set_request_context(RequestContext* context);

}  // namespace rsd::api
