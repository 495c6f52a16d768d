// One HTTP connection to the daemon, over a Unix socket or TCP, on plain sockets
// (socket_io), speaking the little HTTP the daemon needs (http_wire): GETs on a
// kept-alive connection, asked again when the daemon is busy, and SSE streams.
//
// Why not an HTTP library: Debian's libcpp-httplib is a shared library built with
// OpenSSL, brotli and zlib, and loading those was most of a cold `rs-discover list`;
// libcurl drags in more still. The client talks to one local daemon, so the little
// HTTP it needs is written here.
#include "internal.hpp"

#include "http_wire.hpp"
#include "socket_io.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <thread>
#include <vector>

namespace rsdiscovery::detail {

// One socket and what was read past the last reply on it.
struct Transport::Connection {
  int fd = -1;
  std::string buffer;
  ~Connection() {
    if (fd >= 0) ::close(fd);
  }
};

Transport::Transport(Endpoint endpoint, ClientOptions options)
    : endpoint_(std::move(endpoint)), options_(options) {}

Transport::~Transport() = default;

namespace {

using Clock = std::chrono::steady_clock;

// A Content-Length up to this is trusted for one allocation before the body comes;
// beyond, the buffer grows as bytes actually arrive.
constexpr std::size_t kMaxReserve = 16 << 20;

[[noreturn]] void too_large(const Endpoint& endpoint, const std::string& path) {
  throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd at " + endpoint.to_string() +
                                              ": the answer to GET " + path + " is larger than " +
                                              std::to_string(kMaxReply >> 20) + " MiB (not read)");
}

}  // namespace

[[noreturn]] void Transport::fail(int io_end, std::chrono::milliseconds timeout) const {
  switch (static_cast<IoEnd>(io_end)) {
    case IoEnd::cancelled:
      throw Error(ErrorCode::cancelled, "cancelled");
    case IoEnd::timeout:
      throw Error(ErrorCode::timeout, "rs-discoveryd at " + endpoint_.to_string() + " did not answer within " +
                                          std::to_string(timeout.count()) + " ms");
    case IoEnd::ok:
    case IoEnd::closed:
    case IoEnd::failed:
      break;
  }
  throw Error(ErrorCode::not_running, "rs-discoveryd at " + endpoint_.to_string() + " closed the connection");
}

Reply Transport::get(const std::string& path, std::optional<std::chrono::milliseconds> timeout,
                     const std::string& if_none_match) {
  // A 503 with Retry-After is the daemon saying "busy, ask again then" (its
  // connection limit, a participant being made anew): asked again as it says, for
  // up to kBusyBudget in all, before the 503 is the caller's to handle.
  constexpr auto kBusyBudget = std::chrono::seconds(10);
  const auto busy_until = Clock::now() + kBusyBudget;
  for (;;) {
    Reply reply = get_once(path, timeout, if_none_match);
    if (reply.status != 503 || reply.retry_after.empty()) return reply;
    int seconds = 1;
    try {
      seconds = std::clamp(std::stoi(reply.retry_after), 1, 10);
    } catch (const std::exception&) {  // not a number of seconds: once a second
    }
    const auto again = Clock::now() + std::chrono::seconds(seconds);
    if (again > busy_until) return reply;
    if (options_.on_busy())
      options_.on_busy()(std::string(status_error(path, reply).what()) + "; asking again in " +
                       std::to_string(seconds) + " s");
    while (Clock::now() < again) {  // in slices, so cancel() is not kept waiting
      if (cancelled_) throw Error(ErrorCode::cancelled, "cancelled");
      std::this_thread::sleep_for(std::min<Clock::duration>(again - Clock::now(), std::chrono::milliseconds(50)));
    }
  }
}

Reply Transport::get_once(const std::string& path, std::optional<std::chrono::milliseconds> timeout,
                          const std::string& if_none_match) {
  if (cancelled_) throw Error(ErrorCode::cancelled, "cancelled");
  const auto read_timeout = timeout.value_or(options_.request_timeout());
  std::vector<std::pair<std::string, std::string>> extra;
  if (!if_none_match.empty()) extra.emplace_back("If-None-Match", if_none_match);
  const std::string request = get_request(path, "application/json", extra);
  for (int attempt = 0;; ++attempt) {
    const bool reused = kept_ != nullptr;
    if (!kept_) {
      auto fresh = std::make_unique<Connection>();
      fresh->fd = open_socket(endpoint_, options_.connect_timeout());
      if (fresh->fd < 0) throw diagnose_connect(endpoint_);
      std::lock_guard lock(mutex_);
      kept_ = std::move(fresh);
    }
    Connection& c = *kept_;
    const auto deadline = Clock::now() + read_timeout;
    auto end = write_all(c.fd, request, deadline, cancelled_);
    // A daemon at its connection limit answers 503 at once and closes without
    // reading the request: the write fails, yet the answer is there to read.
    if (end == IoEnd::closed) end = IoEnd::ok;
    std::optional<Head> head;
    bool malformed = false;
    while (end == IoEnd::ok && !(head = take_head(c.buffer, malformed)) && !malformed)
      end = read_some(c.fd, c.buffer, deadline, cancelled_);
    if (malformed) {
      drop_kept();
      throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd at " + endpoint_.to_string() +
                                                  ": not an HTTP response to GET " + path);
    }
    if (!head) {
      const bool nothing_came = c.buffer.empty();
      drop_kept();  // `c` is gone from here on
      // A kept-alive connection the daemon closed meanwhile: once more, afresh.
      if (reused && attempt == 0 && nothing_came && end == IoEnd::closed) continue;
      fail(static_cast<int>(end), read_timeout);
    }
    Reply reply;
    reply.status = head->status;
    reply.content_type = head->content_type;
    reply.retry_after = head->retry_after;
    reply.etag = head->etag;
    bool keep = !iequals(head->connection, "close");
    if (head->status == 304 || head->status == 204) {
      // no body
    } else if (iequals(head->transfer_encoding, "chunked")) {
      bool last = false;
      while (!last && !malformed) {
        if (take_chunk(c.buffer, reply.body, last, malformed)) continue;
        if (reply.body.size() + c.buffer.size() > kMaxReply) {
          drop_kept();
          too_large(endpoint_, path);
        }
        if (malformed || (end = read_some(c.fd, c.buffer, deadline, cancelled_)) != IoEnd::ok) break;
      }
      if (!last) {
        drop_kept();
        if (malformed) throw Error(ErrorCode::malformed_reply, "malformed chunked reply from rs-discoveryd");
        fail(static_cast<int>(end), read_timeout);
      }
    } else if (head->content_length) {
      const std::size_t length = *head->content_length;
      if (length > kMaxReply) {  // said at once: nothing of it is read
        drop_kept();
        too_large(endpoint_, path);
      }
      // Room for the whole body at once, and the buffer itself handed over when it
      // holds just the body: a list was otherwise copied again on each step in.
      if (length <= kMaxReserve && c.buffer.capacity() < length) c.buffer.reserve(length);
      while (c.buffer.size() < length && (end = read_some(c.fd, c.buffer, deadline, cancelled_)) == IoEnd::ok) {
      }
      if (c.buffer.size() < length) {
        drop_kept();
        fail(static_cast<int>(end), read_timeout);
      }
      if (c.buffer.size() == length) {
        reply.body = std::move(c.buffer);
        c.buffer = std::string();
      } else {
        reply.body = c.buffer.substr(0, length);
        c.buffer.erase(0, length);
      }
    } else {  // until the daemon closes
      while ((end = read_some(c.fd, c.buffer, deadline, cancelled_)) == IoEnd::ok) {
        if (c.buffer.size() > kMaxReply) {
          drop_kept();
          too_large(endpoint_, path);
        }
      }
      if (end != IoEnd::closed) {
        drop_kept();
        fail(static_cast<int>(end), read_timeout);
      }
      reply.body = std::move(c.buffer);
      keep = false;
    }
    if (!keep) drop_kept();
    return reply;
  }
}

void Transport::drop_kept() {
  std::lock_guard lock(mutex_);
  kept_.reset();
}

Error Transport::status_error(const std::string& path, const Reply& reply) {
  std::string detail;
  detail = json::text_or(json::find(json::parse_or_null(reply.body), "error"));
  std::string where = endpoint_.to_string();
  if (reply.status == 404 || reply.status == 405) {
    std::string daemon_version;
    try {
      auto h = get(std::string("/healthz"));
      daemon_version = json::text_or(json::find(json::parse_or_null(h.body), "version"));
    } catch (const Error&) {
    }
    // No rs-discoveryd's /healthz there either: another server has the address.
    if (daemon_version.empty())
      return Error(ErrorCode::version_mismatch,
                   "something other than rs-discoveryd answers at " + where + ": GET " + path + " got HTTP " +
                       std::to_string(reply.status) + ", and it has no rs-discoveryd /healthz; is the endpoint right?",
                   reply.status);
    return Error(ErrorCode::version_mismatch,
                 "version mismatch: rs-discoveryd at " + where + " does not serve GET " + path +
                     " (HTTP " + std::to_string(reply.status) + "); this client speaks API v1 (" +
                     "library " + version() + ")" +
                     (daemon_version.empty() ? "" : ", the daemon is version " + daemon_version),
                 reply.status);
  }
  return Error(ErrorCode::http_error,
               "rs-discoveryd at " + where + " answered HTTP " + std::to_string(reply.status) +
                   " to GET " + path + (detail.empty() ? "" : ": " + detail),
               reply.status);
}

json::Document Transport::get_json(const std::string& path) {
  Reply reply = get(path);
  if (reply.status != 200) throw status_error(path, reply);
  json::Document doc;
  if (json::parse(reply.body, doc) || !doc.IsObject())
    throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd at " +
                                                endpoint_.to_string() + ": GET " + path +
                                                " did not return a JSON object");
  return doc;
}

void Transport::stream(const std::string& path, const std::string& last_event_id,
                       const std::function<bool()>& on_open,
                       const std::function<bool(const char*, std::size_t)>& on_data,
                       std::chrono::milliseconds idle_timeout) {
  auto c = std::make_shared<Connection>();
  c->fd = open_socket(endpoint_, options_.connect_timeout());
  if (c->fd < 0) {
    if (cancelled_) return;
    throw diagnose_connect(endpoint_);
  }
  {
    std::lock_guard lock(mutex_);
    if (cancelled_) return;
    streaming_ = c;
  }
  struct Unset {
    Transport* t;
    ~Unset() {
      std::lock_guard lock(t->mutex_);
      t->streaming_.reset();
    }
  } unset{this};

  std::vector<std::pair<std::string, std::string>> extra;
  if (!last_event_id.empty()) extra.emplace_back("Last-Event-ID", last_event_id);
  // Every read waits at most the idle timeout: a stream silent longer is dead (the
  // daemon sends keep-alive comments well within it).
  auto deadline = [&] { return Clock::now() + idle_timeout; };
  auto end = write_all(c->fd, get_request(path, "text/event-stream", extra), deadline(), cancelled_);
  std::optional<Head> head;
  bool malformed = false;
  while (end == IoEnd::ok && !(head = take_head(c->buffer, malformed)) && !malformed)
    end = read_some(c->fd, c->buffer, deadline(), cancelled_);
  if (cancelled_) return;
  if (malformed)
    throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd at " + endpoint_.to_string() +
                                                ": not an HTTP response to GET " + path);
  if (!head) fail(static_cast<int>(end), idle_timeout);
  if (head->status != 200) {
    Reply bad;
    bad.status = head->status;
    bad.content_type = head->content_type;
    // The error body, as far as it comes at once (it is small and already sent).
    while (end == IoEnd::ok && (!head->content_length || c->buffer.size() < *head->content_length))
      end = read_some(c->fd, c->buffer, Clock::now() + std::chrono::milliseconds(500), cancelled_);
    bad.body = std::move(c->buffer);
    if (iequals(head->transfer_encoding, "chunked")) {
      std::string decoded;
      bool last = false;
      while (take_chunk(bad.body, decoded, last, malformed) && !last) {
      }
      bad.body = decoded;
    }
    throw status_error(path, bad);
  }
  if (!on_open()) return;
  const bool chunked = iequals(head->transfer_encoding, "chunked");
  for (;;) {
    if (chunked) {
      std::string data;
      bool last = false;
      while (take_chunk(c->buffer, data, last, malformed) && !last) {
      }
      if (!data.empty() && !on_data(data.data(), data.size())) return;
      if (last || malformed) return;  // the daemon ended the stream (it stops)
    } else if (!c->buffer.empty()) {
      if (!on_data(c->buffer.data(), c->buffer.size())) return;
      c->buffer.clear();
    }
    // A chunk is taken whole: one that never ends must not grow the buffer for ever.
    if (c->buffer.size() > kMaxReply) too_large(endpoint_, path);
    end = read_some(c->fd, c->buffer, deadline(), cancelled_);
    if (end == IoEnd::cancelled || end == IoEnd::closed) return;  // ended, by us or the daemon
    if (end != IoEnd::ok) fail(static_cast<int>(end), idle_timeout);
  }
}

void Transport::cancel() {
  cancelled_ = true;
  std::lock_guard lock(mutex_);
  // Wakes a read in progress at once; its loop sees cancelled_ within a poll slice anyway.
  if (streaming_) ::shutdown(streaming_->fd, SHUT_RDWR);
  if (kept_) ::shutdown(kept_->fd, SHUT_RDWR);
}

}  // namespace rsdiscovery::detail
