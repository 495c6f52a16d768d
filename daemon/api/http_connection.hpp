// One API connection's decisions, with no socket and no clock: what the bytes read
// so far make (a request, a refusal), pipelined requests one at a time and in order,
// when a request waits on the blocking pool, when to close after a response, the
// deadlines (a first request, a request begun, an idle keep-alive, a reader that
// takes nothing), what a stop does in each state, and an SSE stream's back-pressure.
// The reactor (reactor.hpp) does the I/O and feeds it events with the time; the
// unit tests feed it made-up bytes and times, as DomainBook's do. Internal to
// daemon/api.
#pragma once

#include "api/request_head.hpp"

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>

namespace rsd::api {

using Clock = std::chrono::steady_clock;
class SharedBody;  // server_loop.hpp

// Stopping: how long a connection accepted but not yet heard from may take to send
// its request. A client sends at once after connecting (microseconds); one that
// connected and says nothing is idle, and must not hold the stop for the grace.
constexpr auto kFirstRequestWait = std::chrono::milliseconds(100);
// An SSE client whose socket takes nothing for this long is gone (or stuck).
constexpr auto kStreamStall = std::chrono::seconds(60);

// What is to be sent on a connection: bytes, then a shared body's part from its
// memfd. The machine appends; the send path (send_path.cpp) takes from the front.
struct Outbox {
  std::string out;
  std::size_t out_pos = 0;
  std::shared_ptr<const SharedBody> file;
  std::size_t file_offset = 0, file_left = 0;
  bool broken = false;  // a send failed: nothing more goes out

  std::size_t out_pending() const { return out.size() - out_pos; }
  std::size_t pending() const { return out_pending() + file_left; }
};

struct ConnectionOptions {
  HeadLimits head;
  std::chrono::milliseconds client_timeout{10000};  // to send a request once begun; to read a response
  std::chrono::milliseconds idle_timeout{60000};    // a kept-alive connection with no request
  std::size_t stream_buffer_limit = 1 << 20;         // unread SSE bytes before a stream is dropped
  // Routes that may block (the request target): parked on the blocking pool.
  std::function<bool(std::string_view target)> blocking;
};

class HttpConnection {
 public:
  enum class State {
    reading,    // waiting for (the rest of) a request
    parked,     // a request is being served on the blocking pool; the loop keeps off
    writing,    // a response is not yet all sent
    streaming,  // an SSE stream, fed by the loop
    closed,
  };
  enum class Interest : std::uint8_t { none, read, write, read_write };
  // What the reactor does next; it reports the outcome with the event named.
  struct Action {
    enum class Kind {
      wait,   // set `interest` and wait for the socket (or a tick)
      send,   // send what `out` holds: then sent()
      serve,  // run the request in in()[0, request_length()): then served()
      park,   // the same on the blocking pool: then served(), or park_refused()
      close,  // close the socket; the machine is done
    } kind = Kind::wait;
    Interest interest = Interest::none;
  };
  // Counted for the loop's statistics as they happen (take_counts()).
  struct Counts {
    unsigned rejected = 0;        // 414/431/413/400/408 before httplib
    unsigned timed_out = 0;       // not sending or not reading in time
    unsigned backlog_drops = 0;   // an SSE client that stopped reading, at the buffer limit
    unsigned stall_drops = 0;     // an SSE client whose socket took nothing for kStreamStall
  };
  // What serving a request did.
  struct Served {
    std::size_t consumed = 0;  // bytes of `in` httplib read
    bool close = false;        // httplib (or a stop) wants the connection closed after it
    bool stream = false;       // the response became an SSE stream
  };

  // A connection just accepted; `stopping`: answered once, then closed.
  HttpConnection(const ConnectionOptions& options, Clock::time_point now, bool stopping);

  // Events.
  void bytes(std::string_view data, Clock::time_point now);  // read from the socket
  void eof();                                                // the client sends no more
  void error();                                              // the socket failed
  void sent(Clock::time_point now, bool progressed);         // after Kind::send
  void writable();                                           // the socket takes bytes again
  void served(const Served& result, Clock::time_point now);  // after Kind::serve or Kind::park
  void park_refused(Clock::time_point now);                  // the blocking pool is full
  void stream_text(std::string_view sse, Clock::time_point now);  // an SSE feed's text
  void tick(Clock::time_point now);                          // deadlines
  void stop(Clock::time_point now);                          // the daemon stops

  // The next thing to do; call until it is `wait` or `close`.
  Action next(Clock::time_point now);

  State state() const { return state_; }
  const std::string& in() const { return in_; }
  std::size_t request_length() const { return request_length_; }
  Outbox& out() { return out_; }
  const Outbox& out() const { return out_; }
  Counts take_counts() { return std::exchange(counts_, Counts{}); }

 private:
  Action process_input(Clock::time_point now);
  void reject(int status, const std::string& message, Clock::time_point now);
  void back_to_reading(Clock::time_point now);

  const ConnectionOptions& options_;
  State state_ = State::reading;
  std::string in_;
  std::size_t scanned_ = 0;         // of an incomplete head (scan_request_head's resume)
  std::size_t request_length_ = 0;  // head and body of the request being served
  Outbox out_;
  bool flush_ = false;              // `out` has bytes not yet offered to the socket
  bool eof_ = false;
  bool close_now_ = false;
  bool close_after_write_ = false;
  bool stopping_ = false;
  bool serving_ = false;            // an action serve/park was given, served() not yet called
  std::size_t served_ = 0;          // responses begun
  Clock::time_point deadline_{};       // reading: the request (or the next one) must be in by then
  Clock::time_point last_progress_{};  // writing, streaming: the last time the client took bytes
  Counts counts_;
};

// The daemon's own response writer, for what the loop answers without httplib: a
// head (the status line, `fields` in the order given, the blank line); a complete
// response of its own (refusals, timeouts); an SSE chunk of the chunked encoding.
struct HeadField {
  std::string_view name, value;
};
std::string response_head(int status, std::span<const HeadField> fields);
std::string canned_response(int status, const std::string& message, bool retry_after);
std::string chunk(std::string_view data);

}  // namespace rsd::api
