// A connection of the API's event loops as its three users see it: the reactor
// (reactor.hpp), the send path (send_path.cpp) and httplib's stream over it
// (connection_stream.cpp). Internal to daemon/api.
#pragma once

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
// Stopping: how long a connection accepted but not yet heard from may take to send
// its request. A client sends at once after connecting (microseconds); one that
// connected and says nothing is idle, and must not hold the stop for the grace.
constexpr auto kFirstRequestWait = std::chrono::milliseconds(100);
// A write this large goes to the socket at once instead of being copied behind
// the headers (a device list is tens of kilobytes).
constexpr std::size_t kDirectWrite = 16 * 1024;
constexpr std::size_t kReadChunk = 16 * 1024;
// An SSE client whose socket takes nothing for this long is gone (or stuck).
constexpr auto kStreamStall = std::chrono::seconds(60);
// After running out of file descriptors, accepting waits this long.
constexpr auto kAcceptPause = std::chrono::milliseconds(100);

enum class ConnState {
  reading,    // waiting for (the rest of) a request
  parked,     // a request is being served on the blocking pool; the loop keeps off
  writing,    // a response is not yet all sent
  streaming,  // an SSE stream, fed by the loop
};

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
  Connection(int f, const LoopListener& l) : Pollable(Kind::connection), fd(f), listener(&l) {}
  const int fd;
  const LoopListener* const listener;
  ConnState state = ConnState::reading;
  std::string in;
  std::size_t scanned = 0;         // of an incomplete head (scan_request_head's resume)
  std::size_t request_length = 0;  // head and body of the request being served
  std::string out;
  std::size_t out_pos = 0;
  // A response body to follow `out` from a memfd (sendfile), and how much is left.
  std::shared_ptr<const SharedBody> file;
  std::size_t file_offset = 0, file_left = 0;
  bool broken = false;             // a send failed: nothing more goes out
  bool close_after_write = false;
  std::size_t served = 0;          // responses begun on this connection
  Clock::time_point deadline{};       // reading: the request (or the next one) must be in by then
  Clock::time_point last_progress{};  // writing, streaming: the last time the client took bytes
  std::shared_ptr<EventFeed> feed;
  std::uint32_t interest = 0;
  // Both ends' addresses, asked of the kernel once: httplib wants them for every
  // request, and two system calls a request showed in the profile.
  struct Address {
    bool known = false;
    std::string ip;
    int port = 0;
  };
  Address local, remote;

  std::size_t out_pending() const { return out.size() - out_pos; }
  std::size_t pending() const { return out_pending() + file_left; }
};

// Sends what `c` has pending, without blocking: `out`, then the body from its memfd
// (through this thread's splice pipe on a Unix socket). false: the connection is dead.
bool send_pending(Connection& c, Clock::time_point now);

// httplib's request context of the request being served on this thread (set by
// the reactor around httplib's processing; connection_stream.cpp).
void set_request_context(RequestContext* context);

// A complete response the loop writes by itself (refusals, timeouts), and an SSE
// chunk of the chunked encoding.
std::string canned_response(int status, const std::string& message, bool retry_after);
std::string chunk(const std::string& data);

}  // namespace rsd::api
