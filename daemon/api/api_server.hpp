// The read-only JSON API, served the same over a Unix socket and over HTTP.
#pragma once

#include "status/status_view.hpp"
#include "table/shared_table.hpp"

#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::api {

struct ApiOptions {
  std::string unix_socket;  // path; empty: no Unix socket
  int unix_socket_gid = -1;  // the group given to the socket the daemon makes; -1: its own
  std::string http_host;    // empty: no HTTP
  int http_port = 0;
  // The configuration named http_host:http_port (or "off"), rather than leaving the
  // default: a passed HTTP socket elsewhere is then a disagreement (/healthz "http").
  bool http_configured = false;
  // Already-bound listening sockets handed over by systemd (-1: none): when set,
  // the server listens on them instead of binding the path/port itself.
  int inherited_unix_fd = -1;
  int inherited_http_fd = -1;

  // HTTP: Host headers answered besides "localhost" and the listening address
  // ("*": any, turning the DNS-rebinding check off).
  std::vector<std::string> allowed_hosts;

  // Connections (see server_loop.hpp): a few event loops serve every client; a
  // client never holds a thread, so these bound memory, not threads.
  int loop_threads = 0;              // 0: loop_threads_for(the CPUs the daemon may use)
  int blocking_threads = 4;          // Camera Discovery requests wait on these
  std::size_t max_connections = 4096;  // over both listeners; beyond, a 503 at once
  int client_timeout_ms = 10000;     // to send a begun request, to take a response
  int idle_timeout_ms = 60000;       // a kept-alive connection between requests
  std::size_t max_event_streams = 1024;  // beyond it /v1/events is a 503
  std::size_t stream_buffer_limit = 1 << 20;  // unread SSE bytes before a stream is dropped
  // Idle SSE streams get a comment line this often, so proxies and NAT boxes keep
  // them open. Tests shorten it.
  int keepalive_ms = 15000;
};

class ApiServer {
 public:
  // `status` is everything the API shows that is not the device table itself
  // (domains, USB, descriptions); it must outlive the server.
  ApiServer(SharedTable& table, const StatusView& status, std::string version);
  ~ApiServer();
  ApiServer(const ApiServer&) = delete;
  ApiServer& operator=(const ApiServer&) = delete;

  // Binds and starts serving on background threads; returns once both listeners
  // accept connections. Throws std::runtime_error with a message fit for the user
  // (address in use; another daemon alive on the socket; permission denied ...).
  void start(const ApiOptions& options);

  // Ends event streams, stops listening, removes the socket file it created.
  // Idempotent; returns promptly (well under a second).
  void stop();

  // The TCP port actually bound (useful with http_port 0), or 0 without HTTP.
  int http_port() const;

  // The raw bytes of one HTTP request answered by the routes as a listener would
  // (`http`: the TCP listener's, Host check and all), without a socket or a loop:
  // for the fuzzer and tests. An event stream answers with its opening only.
  std::string answer(std::string_view request, bool http);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rsd::api
