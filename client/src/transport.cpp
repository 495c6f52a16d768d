// One HTTP connection to the daemon, over a Unix socket or TCP, on cpp-httplib's
// client; and the plain-socket probe that tells a user why connecting failed.
#include "internal.hpp"

#include <httplib.h>

#include <arpa/inet.h>
#include <grp.h>
#include <netdb.h>
#include <pwd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

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

Transport::Transport(Endpoint endpoint, ClientOptions options)
    : endpoint_(std::move(endpoint)), options_(options) {}

Transport::~Transport() = default;

// cpp-httplib 0.18 (Debian trixie) asks for gzip/brotli whenever it was built
// with them, even with set_decompress(false), and then hands over compressed
// bytes: every CLI reply was "not a JSON object" there. Saying what we take,
// explicitly, keeps replies plain with every version (a daemon's own replies are
// small and local; compression buys nothing).
const std::pair<std::string, std::string> kIdentity{"Accept-Encoding", "identity"};

namespace {

std::pair<time_t, time_t> split(std::chrono::milliseconds ms) {
  return {static_cast<time_t>(ms.count() / 1000), static_cast<time_t>((ms.count() % 1000) * 1000)};
}

void set_timeouts(httplib::Client& c, std::chrono::milliseconds read_timeout) {
  auto [rs, rus] = split(read_timeout);
  c.set_read_timeout(rs, rus);
  c.set_write_timeout(rs, rus);
}

}  // namespace

std::unique_ptr<httplib::Client> Transport::make_client(std::chrono::milliseconds read_timeout) const {
  std::unique_ptr<httplib::Client> c;
  if (endpoint_.kind == Endpoint::Kind::unix_socket) {
    c = std::make_unique<httplib::Client>(endpoint_.path, 80);
    c->set_address_family(AF_UNIX);
  } else {
    c = std::make_unique<httplib::Client>(endpoint_.host, endpoint_.port);
    c->set_tcp_nodelay(true);  // keep-alive requests would otherwise wait on Nagle
  }
  auto [cs, cus] = split(options_.connect_timeout);
  c->set_connection_timeout(cs, cus);
  set_timeouts(*c, read_timeout);
  c->set_keep_alive(true);
  c->set_decompress(false);
  return c;
}

void Transport::fail_transport(int httplib_error, Clock::duration elapsed,
                               std::chrono::milliseconds timeout) const {
  auto err = static_cast<httplib::Error>(httplib_error);
  switch (err) {
    case httplib::Error::Connection:
    case httplib::Error::ConnectionTimeout:
    case httplib::Error::BindIPAddress:
      throw diagnose_connect(endpoint_);
    case httplib::Error::Canceled:
      throw Error(ErrorCode::cancelled, "cancelled");
    case httplib::Error::Read:
    case httplib::Error::Write:
      if (elapsed + std::chrono::milliseconds(50) >= timeout)
        throw Error(ErrorCode::timeout, "rs-discoveryd at " + endpoint_.to_string() +
                                            " did not answer within " +
                                            std::to_string(timeout.count()) + " ms");
      throw Error(ErrorCode::not_running,
                  "rs-discoveryd at " + endpoint_.to_string() + " closed the connection");
    default:
      throw Error(ErrorCode::not_running, "cannot talk to rs-discoveryd at " +
                                              endpoint_.to_string() + ": " + httplib::to_string(err));
  }
}

Reply Transport::get(const std::string& path, std::optional<std::chrono::milliseconds> timeout,
                     const std::string& if_none_match) {
  const auto read_timeout = timeout.value_or(options_.request_timeout);
  if (cancelled_) throw Error(ErrorCode::cancelled, "cancelled");
  httplib::Headers headers{{"Host", "localhost"}, {"Accept", "application/json"}, kIdentity};
  if (!if_none_match.empty()) headers.emplace("If-None-Match", if_none_match);
  for (int attempt = 0;; ++attempt) {
    bool reused = http_ && http_->is_socket_open();
    if (!http_) {
      auto fresh = make_client(options_.request_timeout);
      std::lock_guard lock(stream_mutex_);
      http_ = std::move(fresh);
    }
    auto start = Clock::now();
    if (timeout) set_timeouts(*http_, read_timeout);
    auto res = http_->Get(path, headers);
    if (timeout && http_) set_timeouts(*http_, options_.request_timeout);
    if (res) {
      Reply reply;
      reply.status = res->status;
      reply.content_type = res->get_header_value("Content-Type");
      reply.retry_after = res->get_header_value("Retry-After");
      reply.etag = res->get_header_value("ETag");
      reply.body = std::move(res->body);
      return reply;
    }
    auto err = res.error();
    {
      std::lock_guard lock(stream_mutex_);
      http_.reset();  // a failed connection is not reused
    }
    // A kept-alive connection the daemon closed meanwhile: try once more, afresh.
    if (reused && attempt == 0 && (err == httplib::Error::Read || err == httplib::Error::Write))
      continue;
    fail_transport(static_cast<int>(err), Clock::now() - start, read_timeout);
  }
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
  auto client = make_client(idle_timeout);
  client->set_keep_alive(false);
  {
    std::lock_guard lock(stream_mutex_);
    if (cancelled_) return;
    streaming_ = client.get();
  }
  struct Unset {
    Transport* t;
    ~Unset() {
      std::lock_guard lock(t->stream_mutex_);
      t->streaming_ = nullptr;
    }
  } unset{this};

  httplib::Headers headers{{"Host", "localhost"}, {"Accept", "text/event-stream"}, kIdentity};
  if (!last_event_id.empty()) headers.emplace("Last-Event-ID", last_event_id);
  Reply bad;  // a non-200 reply, collected for the error
  bool opened = false, refused = false;
  auto start = Clock::now();
  auto res = client->Get(
      path, headers,
      [&](const httplib::Response& r) {
        if (r.status != 200) {
          bad.status = r.status;
          bad.content_type = r.get_header_value("Content-Type");
          return true;  // read the error body
        }
        opened = true;
        if (cancelled_ || !on_open()) {
          refused = true;
          return false;
        }
        return true;
      },
      [&](const char* data, std::size_t len) {
        if (bad.status) {
          if (bad.body.size() < 65536) bad.body.append(data, len);
          return true;
        }
        if (cancelled_ || !on_data(data, len)) {
          refused = true;
          return false;
        }
        return true;
      });
  if (bad.status) throw status_error(path, bad);
  if (res || opened || refused || cancelled_) return;  // the stream ended (or was ended)
  fail_transport(static_cast<int>(res.error()), Clock::now() - start, idle_timeout);
}

void Transport::cancel() {
  cancelled_ = true;
  std::lock_guard lock(stream_mutex_);
  if (streaming_) streaming_->stop();
  if (http_) http_->stop();
}

}  // namespace rsdiscovery::detail
