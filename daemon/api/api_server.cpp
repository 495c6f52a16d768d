// The API server's wiring: the routes (routes.hpp) onto cpp-httplib servers for the
// Unix socket and HTTP, the request guards around them, the listeners and the
// server loop's lifecycle.
#include "api/api_server.hpp"

#include "api/handlers.hpp"
#include "api/host_check.hpp"
#include "api/listener.hpp"
#include "api/plain_list.hpp"
#include "api/routes.hpp"
#include "api/server_loop.hpp"
#include "log/log.hpp"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <mutex>
#include <optional>
#include <thread>

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sched.h>
#include <sys/stat.h>
#include <unistd.h>

namespace rsd::api {

namespace {

// How long stop() gives answers and streams' last chunks to go out.
constexpr std::chrono::milliseconds kStopGrace{500};
// The API takes no bodies; anything bigger than this is refused before it is read.
constexpr std::size_t kMaxPayload = 64 * 1024;

QuickAnswer quick_answer(PlainList& plain_list) {
  return [&plain_list](std::string_view request, bool stopping, QuickReply& reply) {
    return plain_list.answer(request, stopping, reply);
  };
}

}  // namespace

struct ApiServer::Impl : Handlers {
  std::unique_ptr<RequestServer> unix_server;
  std::unique_ptr<RequestServer> http_server;
  std::unique_ptr<RequestServer> offline_unix, offline_http;  // answer()
  std::unique_ptr<PlainList> unix_plain_list, http_plain_list;  // the plain list, past httplib
  std::unique_ptr<ServerLoop> server_loop;
  std::optional<SharedTable::HookId> change_hook;  // the loop's, while it runs
  int unix_fd = -1;
  int http_fd = -1;
  HostCheck host_check;  // the HTTP listener's

  std::string socket_path;  // the socket file we created and must remove; "" if none
  struct stat socket_stat{};
  int bound_http_port = 0;

  std::mutex lifecycle;
  std::atomic<bool> stopping{false};
  bool started = false;

  using Handlers::Handlers;

  void configure(RequestServer& svr, bool http);
  void start(const ApiOptions& opts);
  void stop();
  void stop_locked();
};

void ApiServer::Impl::configure(RequestServer& svr, bool http) {
  ServerRules rules;
  rules.max_payload = kMaxPayload;
  rules.keep_alive_timeout_s = options.idle_timeout_ms / 1000;
  if (http)
    rules.guard = [this](const ApiRequest& req, ApiResponse& res) {
      const auto host = req.header("Host");
      if (host_check.allows(host)) return false;
      send_error(res, 421,
                 "this daemon does not answer for host '" + host +
                     "'; use its address or localhost (allowed-hosts in the configuration adds names)");
      return true;
    };
  rules.dispatch = [this](const Route& route, const ApiRequest& req, ApiResponse& res) {
    (this->*route.handler)(req, res);
  };
  // Any other method: 405 where the path exists (so a client learns it is
  // read-only), 404 where it does not.
  rules.not_allowed = [](const ApiRequest& req, ApiResponse& res) {
    if (match_route(req.path)) {
      res.set_header("Allow", allowed_methods(req.path));
      send_error(res, 405, "method " + req.method + " not allowed on " + req.path + "; the API is read-only");
    } else {
      send_error(res, 404, "no such path: " + req.path);
    }
  };
  // Whatever httplib answers on its own (no route, unparsable request, too big)
  // still gets a JSON body.
  rules.on_error = [](const ApiRequest& req, ApiResponse& res) {
    std::string message(status_text(res.status));
    if (res.status == 404) message = "no such path: " + req.path;
    if (res.status == 405) res.set_header("Allow", allowed_methods(req.path));
    res.set_content(error_body(res.status, message), kJson);
  };
  rules.on_exception = [](const ApiRequest& req, ApiResponse& res, const std::string& what) {
    log::error("api: " + req.method + " " + req.path + " failed: " + what);
    send_error(res, 500, "internal error");
  };
  rules.answered = [this](std::string_view method, std::string_view target, int code) {
    if (code >= 100 && code < 600) ++requests_by_status[static_cast<std::size_t>(code)];
    if (log::enabled(log::Level::debug))
      log::debug("api: " + std::string(method) + " " + std::string(target) + " -> " + std::to_string(code));
  };
  svr.install(routes(), rules);
}

void ApiServer::Impl::start(const ApiOptions& opts) {
  std::lock_guard lock(lifecycle);
  if (started) throw std::runtime_error("API server already started");
  options = opts;
  stopping = false;
  try {
    std::vector<LoopListener> listeners;
    if (opts.inherited_unix_fd >= 0 || !opts.unix_socket.empty()) {
      std::string where;
      if (opts.inherited_unix_fd >= 0) {
        unix_fd = opts.inherited_unix_fd;  // systemd owns the file; we never remove it
        where = "unix fd " + std::to_string(unix_fd);
      } else {
        unix_fd = listen_unix(opts.unix_socket, opts.unix_socket_gid);
        socket_path = opts.unix_socket;
        lstat(socket_path.c_str(), &socket_stat);
        where = "unix socket " + socket_path;
      }
      unix_server = std::make_unique<RequestServer>(unix_fd);
      configure(*unix_server, false);
      unix_plain_list = std::make_unique<PlainList>(*this, *unix_server, nullptr);
      listeners.push_back({unix_fd, unix_server.get(), false, where, quick_answer(*unix_plain_list)});
    }
    if (opts.inherited_http_fd >= 0 || !opts.http_host.empty()) {
      std::string where;
      if (opts.inherited_http_fd >= 0) {
        http_fd = opts.inherited_http_fd;
        int yes = 1;
        // Accepted sockets inherit TCP_NODELAY from the listener on Linux.
        setsockopt(http_fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
        where = "http fd " + std::to_string(http_fd);
      } else {
        http_fd = listen_tcp(opts.http_host, opts.http_port);
        where = "http " + opts.http_host + ":" + std::to_string(bound_port(http_fd));
      }
      bound_http_port = bound_port(http_fd);
      host_check = HostCheck({opts.http_host, bound_address(http_fd)}, bound_to_any(http_fd), opts.allowed_hosts);
      if (!bound_to_loopback(http_fd))
        log::warning("api: HTTP listens on " + where +
                     ", beyond this machine: every host that reaches it can read the camera inventory and its "
                     "addresses (the API has no authentication); bind it to 127.0.0.1 unless that is meant");
      if (!host_check.enabled()) log::warning("api: allowed-hosts has \"*\": HTTP answers any Host header");
      http_server = std::make_unique<RequestServer>(http_fd);
      configure(*http_server, true);
      http_plain_list = std::make_unique<PlainList>(*this, *http_server, &host_check);
      listeners.push_back({http_fd, http_server.get(), true, where, quick_answer(*http_plain_list)});
    }
    http_status = http_health(opts.http_host, opts.http_port, opts.http_configured,
                              http_fd >= 0 ? bound_address(http_fd) : "", bound_http_port, opts.inherited_http_fd >= 0);
    // The socket unit decides under systemd; a configuration naming another address
    // was changed in one place only, and clients going by it find nothing there.
    if (!http_status.agrees)
      log::warning("api: HTTP listens on " + http_status.listening +
                   " (the socket unit's ListenStream=), but the configuration's \"http\" is " + http_status.configured +
                   ": under systemd the socket unit decides; change the address there ('systemctl edit "
                   "rs-discoveryd.socket') and make \"http\" the same, or leave it out");

    LoopOptions lo;
    if (opts.loop_threads > 0) {
      lo.threads = opts.loop_threads;
    } else {  // the CPUs this process may run on (its affinity, as systemd's CPUAffinity= sets it)
      cpu_set_t cpus;
      const int n = sched_getaffinity(0, sizeof cpus, &cpus) == 0 ? CPU_COUNT(&cpus)
                                                                    : static_cast<int>(std::thread::hardware_concurrency());
      lo.threads = loop_threads_for(n);
    }
    lo.blocking_threads = opts.blocking_threads;
    lo.max_connections = opts.max_connections;
    lo.client_timeout = std::chrono::milliseconds(opts.client_timeout_ms);
    lo.idle_timeout = std::chrono::milliseconds(opts.idle_timeout_ms);
    lo.stream_buffer_limit = opts.stream_buffer_limit;
    lo.blocking = blocking_target;
    // One request through each server before the loops exist: cpp-httplib makes
    // function-local statics on its first request (parse_request_line's set of
    // methods), and made here, on one thread, they are made before any loop runs
    // (which also spares ThreadSanitizer a race it cannot see the guard of).
    for (auto* server : {unix_server.get(), http_server.get()})
      if (server) serve_in_memory(*server, "GET /healthz HTTP/1.1\r\nHost: localhost\r\n\r\n");
    server_loop = std::make_unique<ServerLoop>(lo);
    loop = server_loop.get();
    server_loop->start(listeners);
    change_hook = table.add_change_hook([l = loop] { l->notify_change(); });
    for (const auto& l : listeners) log::info("api: listening on " + l.name);
  } catch (...) {
    started = true;  // so that stop_locked() undoes what did start
    stop_locked();
    throw;
  }
  started = true;
}

void ApiServer::Impl::stop() {
  std::lock_guard lock(lifecycle);
  stop_locked();
}

void ApiServer::Impl::stop_locked() {
  if (!started) return;
  stopping = true;
  // No change reaches the loop once this returns (the hook is not running).
  if (change_hook) table.remove_change_hook(*change_hook);
  change_hook.reset();
  if (server_loop) server_loop->stop(kStopGrace);
  loop = nullptr;
  server_loop.reset();
  // systemd's sockets are closed too: systemd keeps its own copy listening for
  // the next start; ours only must not outlive the server.
  for (int* fd : {&unix_fd, &http_fd})
    if (*fd >= 0) {
      ::close(*fd);
      *fd = -1;
    }
  unix_plain_list.reset();
  http_plain_list.reset();
  unix_server.reset();
  http_server.reset();
  if (!socket_path.empty()) {
    // Only our own file: if another daemon replaced it meanwhile, it is theirs.
    struct stat now{};
    if (lstat(socket_path.c_str(), &now) == 0 && now.st_ino == socket_stat.st_ino && now.st_dev == socket_stat.st_dev)
      unlink(socket_path.c_str());
    socket_path.clear();
  }
  bound_http_port = 0;
  http_status = {};
  started = false;
}

ApiServer::ApiServer(SharedTable& table, const StatusView& status, std::string version)
    : impl_(std::make_unique<Impl>(table, status, std::move(version))) {}

ApiServer::~ApiServer() { stop(); }

void ApiServer::start(const ApiOptions& options) { impl_->start(options); }

void ApiServer::stop() { impl_->stop(); }

int ApiServer::http_port() const { return impl_->bound_http_port; }

std::string ApiServer::answer(std::string_view request, bool http) {
  // Configured once per kind, as start() configures the listeners' servers; any
  // value but INVALID_SOCKET keeps httplib writing bodies (see RequestServer).
  auto& server = http ? impl_->offline_http : impl_->offline_unix;
  if (!server) {
    server = std::make_unique<RequestServer>(0);
    impl_->configure(*server, http);
  }
  return serve_in_memory(*server, request);
}

}  // namespace rsd::api
