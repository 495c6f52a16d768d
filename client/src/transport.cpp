// One HTTP connection to the daemon, over a Unix socket or TCP, on plain sockets;
// and the probe that tells a user why connecting failed.
#include "internal.hpp"


#include <arpa/inet.h>
#include <grp.h>
#include <netdb.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pwd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <thread>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace rsdiscovery::detail {

namespace {

using Clock = std::chrono::steady_clock;

std::string group_name(gid_t gid) {
  if (const group* g = getgrgid(gid)) return g->gr_name;
  return std::to_string(gid);
}
std::string user_name(uid_t uid) {
  if (const passwd* p = getpwuid(uid)) return p->pw_name;
  return std::to_string(uid);
}

std::string hint() {
  return "is rs-discoveryd running? Give another endpoint with --endpoint or "
         "RS_DISCOVERY_ENDPOINT";
}

Error unix_error(const std::string& path, int err) {
  switch (err) {
    case ENOENT:
    case ENOTDIR:
      return Error(ErrorCode::not_running,
                   "cannot reach rs-discoveryd: no socket at " + path + " (" + hint() + ")");
    case ECONNREFUSED:
      return Error(ErrorCode::not_running, "cannot reach rs-discoveryd: nothing listens on " +
                                               path + " (a stale socket file; " + hint() + ")");
    case EACCES:
    case EPERM: {
      std::string msg = "permission denied on " + path;
      struct stat st {};
      if (::stat(path.c_str(), &st) == 0) {
        char mode[8];
        std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
        msg += " (owned by " + user_name(st.st_uid) + ":" + group_name(st.st_gid) + ", mode " +
               mode + "; this user is " + user_name(geteuid()) + ": join group " +
               group_name(st.st_gid) + " or ask the administrator)";
      } else {
        msg += " (a directory on the way to it is not accessible to this user)";
      }
      return Error(ErrorCode::permission_denied, msg);
    }
    default:
      return Error(ErrorCode::not_running,
                   "cannot reach rs-discoveryd at " + path + ": " + std::strerror(err));
  }
}

}  // namespace

Error diagnose_connect(const Endpoint& endpoint) {
  if (endpoint.kind == Endpoint::Kind::unix_socket) {
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (endpoint.path.size() >= sizeof addr.sun_path)
      return Error(ErrorCode::bad_endpoint, "socket path too long: " + endpoint.path);
    std::memcpy(addr.sun_path, endpoint.path.c_str(), endpoint.path.size() + 1);
    int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return unix_error(endpoint.path, errno);
    int rc = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    int err = errno;
    ::close(fd);
    if (rc == 0)  // it answers now: it was busy or restarting
      return Error(ErrorCode::not_running,
                   "rs-discoveryd at " + endpoint.path + " closed the connection");
    return unix_error(endpoint.path, err);
  }
  std::string where = endpoint.to_string();
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  int gai = ::getaddrinfo(endpoint.host.c_str(), std::to_string(endpoint.port).c_str(), &hints, &res);
  if (gai != 0)
    return Error(ErrorCode::not_running, "cannot resolve " + endpoint.host + ": " + gai_strerror(gai));
  int err = ECONNREFUSED;
  for (addrinfo* ai = res; ai; ai = ai->ai_next) {
    int fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
    if (fd < 0) continue;
    int rc = ::connect(fd, ai->ai_addr, ai->ai_addrlen);
    err = rc == 0 ? 0 : errno;
    ::close(fd);
    if (rc == 0) break;
  }
  ::freeaddrinfo(res);
  if (err == 0)
    return Error(ErrorCode::not_running, "rs-discoveryd at " + where + " closed the connection");
  if (err == ECONNREFUSED)
    return Error(ErrorCode::not_running,
                 "cannot reach rs-discoveryd: nothing listens on " + where + " (" + hint() + ")");
  return Error(ErrorCode::not_running,
               "cannot reach rs-discoveryd at " + where + ": " + std::strerror(err));
}

// The connection: a plain socket, and HTTP/1.1 for exactly what rs-discoveryd
// speaks (GET; replies with Content-Length, chunked, or until close). Why not an
// HTTP library: Debian's libcpp-httplib is a shared library built with OpenSSL,
// brotli and zlib, and loading those was most of a CLI run (13 shared objects; a cold
// `rs-discover list` took 6.4x /bin/true); libcurl drags in more still. The client
// talks to one local daemon, so the little HTTP it needs is written here.
namespace {

int open_socket(const Endpoint& endpoint, std::chrono::milliseconds timeout) {
  auto connect_with_timeout = [&](int fd, const sockaddr* addr, socklen_t len) {
    if (::connect(fd, addr, len) == 0) return true;
    if (errno != EINPROGRESS && errno != EAGAIN) return false;
    pollfd p{fd, POLLOUT, 0};
    if (::poll(&p, 1, static_cast<int>(timeout.count())) != 1) return false;
    int err = 0;
    socklen_t n = sizeof err;
    return ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &n) == 0 && err == 0;
  };
  if (endpoint.kind == Endpoint::Kind::unix_socket) {
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (endpoint.path.size() >= sizeof addr.sun_path) return -1;
    std::memcpy(addr.sun_path, endpoint.path.c_str(), endpoint.path.size() + 1);
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd >= 0 && connect_with_timeout(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr)) return fd;
    if (fd >= 0) ::close(fd);
    return -1;
  }
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  if (::getaddrinfo(endpoint.host.c_str(), std::to_string(endpoint.port).c_str(), &hints, &res) != 0) return -1;
  int fd = -1;
  for (addrinfo* ai = res; ai && fd < 0; ai = ai->ai_next) {
    fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, ai->ai_protocol);
    if (fd < 0) continue;
    if (!connect_with_timeout(fd, ai->ai_addr, ai->ai_addrlen)) {
      ::close(fd);
      fd = -1;
    }
  }
  ::freeaddrinfo(res);
  if (fd >= 0) {
    int yes = 1;  // a request goes out whole, at once
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
  }
  return fd;
}

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

std::string_view trim(std::string_view v) {
  while (!v.empty() && (v.front() == ' ' || v.front() == '\t')) v.remove_prefix(1);
  while (!v.empty() && (v.back() == ' ' || v.back() == '\t' || v.back() == '\r')) v.remove_suffix(1);
  return v;
}

}  // namespace

// One socket and what was read past the last reply on it.
struct Transport::Connection {
  int fd = -1;
  std::string buffer;
  ~Connection() {
    if (fd >= 0) ::close(fd);
  }
};

// Why a read or write ended early.
enum class IoEnd { ok, closed, timeout, cancelled, failed };

namespace {

struct Head {
  int status = 0;
  std::string content_type, retry_after, etag, transfer_encoding, connection;
  std::optional<std::size_t> content_length;
};

}  // namespace

Transport::Transport(Endpoint endpoint, ClientOptions options)
    : endpoint_(std::move(endpoint)), options_(options) {}

Transport::~Transport() = default;

namespace {

// Waits for the socket to be readable (or writable) until `deadline`.
IoEnd wait_for(int fd, short events, Clock::time_point deadline, const std::atomic<bool>& cancelled) {
  for (;;) {
    if (cancelled) return IoEnd::cancelled;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return IoEnd::timeout;
    pollfd p{fd, events, 0};
    // A slice at most, so that cancel() is seen without a wake-up of its own.
    const int rc = ::poll(&p, 1, static_cast<int>(std::min<long long>(left, 100)));
    if (rc > 0) return IoEnd::ok;
    if (rc < 0 && errno != EINTR) return IoEnd::failed;
  }
}

IoEnd write_all(int fd, std::string_view data, Clock::time_point deadline, const std::atomic<bool>& cancelled) {
  while (!data.empty()) {
    const ssize_t n = ::send(fd, data.data(), data.size(), MSG_NOSIGNAL);
    if (n > 0) {
      data.remove_prefix(static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      if (const auto w = wait_for(fd, POLLOUT, deadline, cancelled); w != IoEnd::ok) return w;
      continue;
    }
    return IoEnd::closed;
  }
  return IoEnd::ok;
}

// A Content-Length up to this is trusted for one allocation before the body comes;
// beyond, the buffer grows as bytes actually arrive.
constexpr std::size_t kMaxReserve = 16 << 20;

[[noreturn]] void too_large(const Endpoint& endpoint, const std::string& path) {
  throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd at " + endpoint.to_string() +
                                              ": the answer to GET " + path + " is larger than " +
                                              std::to_string(kMaxReply >> 20) + " MiB (not read)");
}

// Appends what the socket has to `buffer`, waiting until `deadline` for something.
IoEnd read_some(int fd, std::string& buffer, Clock::time_point deadline, const std::atomic<bool>& cancelled) {
  char chunk[16384];
  for (;;) {
    const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
    if (n > 0) {
      buffer.append(chunk, static_cast<std::size_t>(n));
      return IoEnd::ok;
    }
    if (n == 0) return IoEnd::closed;
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) return IoEnd::closed;
    if (const auto w = wait_for(fd, POLLIN, deadline, cancelled); w != IoEnd::ok) return w;
  }
}

// The status line and headers at the front of `buffer`, once all there; consumes them.
std::optional<Head> take_head(std::string& buffer, bool& malformed) {
  const auto end = buffer.find("\r\n\r\n");
  if (end == std::string::npos) {
    malformed = buffer.size() > 65536;
    return std::nullopt;
  }
  Head head;
  std::string_view text(buffer.data(), end);
  const auto eol = text.find("\r\n");
  const auto status_line = text.substr(0, eol);
  if (status_line.substr(0, 5) != "HTTP/" || status_line.size() < 12) {
    malformed = true;
    return std::nullopt;
  }
  head.status = std::atoi(std::string(status_line.substr(9, 3)).c_str());
  text = eol == std::string_view::npos ? std::string_view{} : text.substr(eol + 2);
  while (!text.empty()) {
    const auto next = text.find("\r\n");
    const auto line = text.substr(0, next);
    text = next == std::string_view::npos ? std::string_view{} : text.substr(next + 2);
    const auto colon = line.find(':');
    if (colon == std::string_view::npos) continue;
    const auto name = trim(line.substr(0, colon));
    const auto value = std::string(trim(line.substr(colon + 1)));
    if (iequals(name, "Content-Length")) {
      char* stop = nullptr;
      const auto n = std::strtoull(value.c_str(), &stop, 10);
      if (value.empty() || *stop) {
        malformed = true;
        return std::nullopt;
      }
      head.content_length = static_cast<std::size_t>(n);
    } else if (iequals(name, "Content-Type")) {
      head.content_type = value;
    } else if (iequals(name, "Retry-After")) {
      head.retry_after = value;
    } else if (iequals(name, "ETag")) {
      head.etag = value;
    } else if (iequals(name, "Transfer-Encoding")) {
      head.transfer_encoding = value;
    } else if (iequals(name, "Connection")) {
      head.connection = value;
    }
  }
  buffer.erase(0, end + 4);
  return head;
}

// Takes the next chunk of a chunked body off the front of `buffer`: its bytes in
// `out`; true when one was whole, with `last` set at the terminating chunk.
bool take_chunk(std::string& buffer, std::string& out, bool& last, bool& malformed) {
  const auto eol = buffer.find("\r\n");
  if (eol == std::string::npos) {
    malformed = buffer.size() > 64;
    return false;
  }
  char* stop = nullptr;
  const auto size = std::strtoull(buffer.c_str(), &stop, 16);
  if (stop == buffer.c_str()) {
    malformed = true;
    return false;
  }
  if (size == 0) {
    // The last chunk; trailers are not used by the daemon: up to the blank line.
    const auto end = buffer.find("\r\n\r\n", eol);
    if (end == std::string::npos && buffer.compare(eol, 4, "\r\n\r\n") != 0) return false;
    buffer.erase(0, (end == std::string::npos ? eol : end) + 4);
    last = true;
    return true;
  }
  if (buffer.size() < eol + 2 + size + 2) return false;
  out.append(buffer, eol + 2, size);
  buffer.erase(0, eol + 2 + size + 2);
  return true;
}

}  // namespace

std::string Transport::request_text(const std::string& path, const char* accept,
                                    const std::vector<std::pair<std::string, std::string>>& extra) const {
  std::string out = "GET " + path + " HTTP/1.1\r\nHost: localhost\r\nAccept: " + accept +
                    "\r\nAccept-Encoding: identity\r\nUser-Agent: rsdiscovery/" + version() + "\r\n";
  for (const auto& [k, v] : extra) out += k + ": " + v + "\r\n";
  return out + "\r\n";
}

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
    if (options_.on_busy)
      options_.on_busy(std::string(status_error(path, reply).what()) + "; asking again in " +
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
  const auto read_timeout = timeout.value_or(options_.request_timeout);
  std::vector<std::pair<std::string, std::string>> extra;
  if (!if_none_match.empty()) extra.emplace_back("If-None-Match", if_none_match);
  const std::string request = request_text(path, "application/json", extra);
  for (int attempt = 0;; ++attempt) {
    const bool reused = kept_ != nullptr;
    if (!kept_) {
      auto fresh = std::make_unique<Connection>();
      fresh->fd = open_socket(endpoint_, options_.connect_timeout);
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
      // holds just the body: a 51 KB list was copied three times on its way in.
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
  auto doc = nlohmann::json::parse(reply.body, nullptr, false);
  if (doc.is_object() && doc.contains("error") && doc["error"].is_string())
    detail = doc["error"].get<std::string>();
  std::string where = endpoint_.to_string();
  if (reply.status == 404 || reply.status == 405) {
    std::string daemon_version;
    try {
      auto h = get(std::string("/healthz"));
      auto hd = nlohmann::json::parse(h.body, nullptr, false);
      if (hd.is_object() && hd.contains("version") && hd["version"].is_string())
        daemon_version = hd["version"].get<std::string>();
    } catch (const Error&) {
    }
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

nlohmann::json Transport::get_json(const std::string& path) {
  Reply reply = get(path);
  if (reply.status != 200) throw status_error(path, reply);
  auto doc = nlohmann::json::parse(reply.body, nullptr, false);
  if (doc.is_discarded() || !doc.is_object())
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
  c->fd = open_socket(endpoint_, options_.connect_timeout);
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
  auto end = write_all(c->fd, request_text(path, "text/event-stream", extra), deadline(), cancelled_);
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
