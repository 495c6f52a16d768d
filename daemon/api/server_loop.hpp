// The API's connections: a few event-loop threads own every client socket, read
// requests without blocking and run httplib on a request only once it has fully
// arrived; event streams are fed from the loop on table changes. So no client,
// however slow, idle or numerous, holds a thread that others need (cpp-httplib's
// own server parks a worker per connection, and one per SSE stream).
#pragma once

#include "api/httplib_seam.hpp"
#include "api/request_head.hpp"

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::api {

using Clock = std::chrono::steady_clock;

// One SSE client's feed. The loop asks it for text on every table change and at
// each sweep; the feed decides what to send (events, a resync, a keep-alive).
class EventFeed {
 public:
  virtual ~EventFeed() = default;
  // SSE-framed text to send now, "" if nothing.
  virtual std::string poll(Clock::time_point now) = 0;
};

// Response bytes that many requests share (a /v1/devices list of one table
// generation), also held in a sealed memfd so that the loop hands them to the socket
// with sendfile, without copying them, as nginx serves a file: copying the list into
// each socket was what kept the daemon below nginx on the Unix socket (bench/, http).
// Small bodies are not worth the memfd. A body that fits in a pipe is also held in
// one, whose pages a response takes by reference (tee) without looking each up in
// the memfd again.
class SharedBody {
 public:
  explicit SharedBody(std::string bytes);
  ~SharedBody();
  SharedBody(const SharedBody&) = delete;
  SharedBody& operator=(const SharedBody&) = delete;
  const std::string& bytes() const { return bytes_; }
  int fd() const { return fd_; }  // -1: served by copy
  int pipe() const { return pipe_read_; }  // the whole body, never read; -1: none

 private:
  void fill_pipe();
  std::string bytes_;
  int fd_ = -1;
  int pipe_read_ = -1;
};

// What a route handler knows of the request besides httplib's Request, and how it
// turns its response into an event stream. Valid during the handler only.
struct RequestContext {
  bool http = false;  // came in on the TCP listener (not the Unix socket)
  // Set by the /v1/events handler from its content provider: after the first
  // chunk (headers and the stream's opening), the loop takes the connection over.
  std::shared_ptr<EventFeed> adopt_as_stream;
  // Set by write_shared around its write: which shared body the bytes come from.
  std::shared_ptr<const SharedBody> body;
  std::size_t body_offset = 0;

  static RequestContext* current();
};

// The event loops for `cpus` CPUs: one for every two, one at least and two at most.
// The daemon shares its host with the programs it answers (a robot's, a bench's):
// on two cores, two loops busy with 64 connections took the core their clients
// needed and lengthened the clients' tail, and one loop still answered more
// requests than nginx's two workers (bench/ http).
int loop_threads_for(int cpus);

struct LoopOptions {
  int threads = 2;                // event loops; each request is served on one
  int blocking_threads = 4;       // for routes that wait (Camera Discovery)
  std::size_t max_connections = 4096;  // over every listener; beyond, a 503 at once
  std::size_t max_blocking = 64;  // requests waiting in or for the blocking pool
  std::chrono::milliseconds client_timeout{10000};  // to send a request once begun; to read a response
  std::chrono::milliseconds idle_timeout{60000};    // a kept-alive connection with no request
  std::size_t stream_buffer_limit = 1 << 20;         // unread SSE bytes before a stream is dropped
  HeadLimits head;
  // Routes that may block (the request target): served on the blocking pool.
  std::function<bool(std::string_view target)> blocking;
};

// A response the loop sends without running httplib: a head, then a shared body.
struct QuickReply {
  std::string_view head;                   // valid until the loop's next request on this thread
  std::shared_ptr<const SharedBody> body;  // null: the head is all
  bool close = false;                      // close the connection after it
};
// Answers the one complete request it is given (head and body) when it knows how,
// else returns false and httplib serves it. Called on the loop's threads.
using QuickAnswer = std::function<bool(std::string_view request, bool stopping, QuickReply& reply)>;

struct LoopListener {
  int fd = -1;  // bound and listening (or -1: see adopt); the loop makes it non-blocking, never closes it
  RequestServer* server = nullptr;
  bool http = false;
  std::string name;
  QuickAnswer quick;  // optional: tried before httplib on each request
};

struct LoopStats {
  std::size_t connections = 0;
  std::size_t streams = 0;
  std::uint64_t refused = 0;          // 503 at accept: the connection limit
  std::uint64_t timed_out = 0;        // closed for not sending or not reading in time
  std::uint64_t streams_dropped = 0;  // SSE clients that stopped reading
  std::uint64_t rejected = 0;         // 414/431/413/400 before httplib
};

class ServerLoop {
 public:
  explicit ServerLoop(LoopOptions options);
  ~ServerLoop();
  ServerLoop(const ServerLoop&) = delete;
  ServerLoop& operator=(const ServerLoop&) = delete;

  // Throws (a listener the kernel will not watch, no epoll) and is then not
  // started: nothing is left running.
  void start(std::vector<LoopListener> listeners);
  // A connected socket accepted elsewhere, served as if accepted on
  // listeners[listener] (the unit tests give it one end of a socketpair; a
  // listener whose fd is -1 is only a name for such connections). Takes `fd`.
  void adopt(int fd, std::size_t listener);
  // From any thread: the table changed; streams poll their feeds.
  void notify_change();
  // Stops accepting, answers requests that have fully arrived, ends streams with
  // their final chunk, and closes everything within `grace` (requests on the
  // blocking pool are waited for). Idempotent.
  void stop(std::chrono::milliseconds grace);

  LoopStats stats() const;

  struct Impl;  // opaque; public so the loop's own file can name it

 private:
  void make_reactors();  // one per thread, watching every listener; throws

  std::unique_ptr<Impl> impl_;
};

}  // namespace rsd::api
