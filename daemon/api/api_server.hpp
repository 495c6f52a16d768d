// The read-only JSON API, served the same over a Unix socket and over HTTP.
#pragma once

#include "status/status_source.hpp"
#include "table/shared_table.hpp"

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace rsd::api {

struct ApiOptions {
  std::string unix_socket;  // path; empty: no Unix socket
  std::string http_host;    // empty: no HTTP
  int http_port = 0;
  // Already-bound listening sockets handed over by systemd (-1: none): when set,
  // the server listens on them instead of binding the path/port itself.
  int inherited_unix_fd = -1;
  int inherited_http_fd = -1;

  // Every open SSE client holds one worker thread for as long as it listens, so
  // each listener gets a pool well above the stream limit: plain requests keep
  // being answered when all streams are taken.
  int worker_threads = 64;  // per listener
  int max_event_streams = 32;  // over both listeners; beyond it /v1/events is a 503
  // Idle SSE streams get a comment line this often, so proxies and NAT boxes keep
  // them open. Tests shorten it.
  int keepalive_ms = 15000;
};

class ApiServer {
 public:
  // `status` is everything the API shows that is not the device table itself
  // (domains, USB, descriptions); it must outlive the server.
  ApiServer(SharedTable& table, const StatusSource& status, std::string version);
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

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rsd::api
