// The one place the daemon meets cpp-httplib, and why each piece is here. The
// loops read, time and close connections themselves (HttpConnection, Reactor),
// and the handlers are functions of the API's own request and response
// (exchange.hpp); from httplib the daemon takes only its request parsing, routing
// and response writing, run on a request already read whole:
//  - RequestServer: httplib::Server, given the routes and the API's rules in the
//    API's own types (install), plus a call of its process_request on our stream.
//  - ConnectionStream (a loop connection) and serve_in_memory (a request held in
//    memory, for ApiServer::answer): the httplib::Stream that process_request reads
//    and writes.
//  - What a head the daemon writes itself must share with httplib's for the same
//    response (the plain list's): the Keep-Alive value and the order of the fields
//    (field_order).
//  - An ApiResponse's shared body goes out through a content provider whose write
//    the loop turns into sendfile/splice from the memfd instead of a copy; its
//    event stream through a chunked provider whose first chunk hands the
//    connection to the loop.
//  - BlockingPool: httplib's ThreadPool, which parked requests run on.
//
// No public way: httplib (0.11 on bookworm, 0.18 on trixie, and 0.53 upstream
// alike) runs parsing and routing only from its own listen()/listen_after_bind()
// loop, which reads each connection with a blocking worker per connection (the
// thing this loop exists to avoid); new_task_queue only chooses the thread that
// blocking worker runs on. process_request, which takes any Stream, is protected,
// so RequestServer subclasses Server to call it, the one protected member it
// calls. Content providers stop once svr_sock_ is INVALID_SOCKET; the only public
// ways to set it (bind_to_port, bind_to_any_port) open and bind a TCP socket of
// httplib's own, so RequestServer's constructor sets the protected member instead.
// The per-request context (RequestContext) travels in a thread_local:
// process_request's setup_request callback sees the Request first, but 0.11's
// Request has no field of ours to carry it in.
#pragma once

#include <httplib.h>

#include "api/exchange.hpp"

#include <cstddef>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::api {

class SharedBody;  // server_loop.hpp
struct Connection;  // connection.hpp
struct Route;       // routes.hpp

// What the API asks of a RequestServer, in its own types.
struct ServerRules {
  std::size_t max_payload = 64 * 1024;  // a larger body is refused (413) before it is read
  int keep_alive_timeout_s = 5;         // only what the Keep-Alive header says: the loop decides
  // Before routing: answers the request itself when it must not go on (true).
  std::function<bool(const ApiRequest&, ApiResponse&)> guard;
  // A routed GET (or HEAD, answered as httplib answers it: the GET's head).
  std::function<void(const Route&, const ApiRequest&, ApiResponse&)> dispatch;
  // Any other method, on any path.
  std::function<void(const ApiRequest&, ApiResponse&)> not_allowed;
  // What httplib answers on its own (no route, an unparsable or too large request):
  // `res.status` is set, the rest is to fill.
  std::function<void(const ApiRequest&, ApiResponse&)> on_error;
  // A handler threw `what`.
  std::function<void(const ApiRequest&, ApiResponse&, const std::string& what)> on_exception;
  // After each answer httplib wrote.
  std::function<void(std::string_view method, std::string_view target, int status)> answered;
};

// httplib's request parsing, routing and response writing, run on a request the
// loop has already read.
class RequestServer : public httplib::Server {
 public:
  // httplib stops writing a response body once it believes its server socket
  // closed (svr_sock_ invalid); this server has none of its own, so it carries
  // the listener's. httplib never uses it otherwise here (no listen(), no stop()).
  explicit RequestServer(int listener_fd) { svr_sock_ = listener_fd; }
  // Registers `routes` and `rules`; once, before the first request.
  void install(std::span<const Route> routes, const ServerRules& rules);
  // The Keep-Alive header's value on a response that keeps the connection.
  const std::string& keep_alive_value() const { return keep_alive_value_; }
  // false: the connection must close after what was written.
  bool serve(httplib::Stream& stream, bool close_connection, bool& connection_closed) {
    return serve_on(*this, stream, close_connection, connection_closed);
  }

 private:
  // cpp-httplib 0.11 (bookworm) asks the stream for the two addresses; later ones
  // (0.18, trixie) take them as arguments. A template, so that only the form this
  // httplib has is compiled.
  template <typename Server>
  static bool serve_on(Server& server, httplib::Stream& stream, bool close_connection, bool& connection_closed) {
    if constexpr (requires { server.process_request(stream, close_connection, connection_closed, nullptr); }) {
      return server.process_request(stream, close_connection, connection_closed, nullptr);
    } else {
      std::string remote_ip, local_ip;
      int remote_port = 0, local_port = 0;
      stream.get_remote_ip_and_port(remote_ip, remote_port);
      stream.get_local_ip_and_port(local_ip, local_port);
      return server.process_request(stream, remote_ip, remote_port, local_ip, local_port, close_connection,
                                    connection_closed, nullptr);
    }
  }

  std::string keep_alive_value_;
};

// The order httplib writes a response's header fields in, given the order they were
// set in (`names`, distinct): a permutation of their indices. It is its header
// map's iteration order, sorted by name in 0.11 and hashed in 0.18 and later, so it
// is taken from that map, filled as httplib fills it.
std::vector<std::size_t> field_order(std::span<const std::string_view> names);

// httplib's view of a loop connection: the request from the machine's buffer, the
// response into its outbox (large bodies straight to the socket, a shared body
// from its memfd).
class ConnectionStream final : public httplib::Stream {
 public:
  explicit ConnectionStream(Connection& c) : c_(c) {}
  std::size_t consumed() const { return pos_; }

  bool is_readable() const override;
  bool is_writable() const override;
  ssize_t read(char* ptr, size_t size) override;
  ssize_t write(const char* ptr, size_t size) override;
  void get_remote_ip_and_port(std::string& ip, int& port) const override { address(false, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address(true, ip, port); }
  socket_t socket() const override;

 private:
  void address(bool local, std::string& ip, int& port) const;

  Connection& c_;
  std::size_t pos_ = 0;
};

// `server`'s answer to `request`, held in memory (ApiServer::answer).
std::string serve_in_memory(RequestServer& server, std::string_view request);

// An httplib content provider's write of `body` from `offset`: from the memfd when
// the loop serves the request, else a plain copy.
bool write_shared(httplib::DataSink& sink, const std::shared_ptr<const SharedBody>& body, std::size_t offset,
                  std::size_t length);

using BlockingPool = httplib::ThreadPool;

}  // namespace rsd::api
