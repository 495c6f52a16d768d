// The one place the API's event loops meet cpp-httplib, and why each piece is here.
// The loops read, time and close connections themselves (HttpConnection, Reactor)
// and take from httplib only its request parsing, routing and response writing,
// run on a request already read whole:
//  - RequestServer: httplib::Server plus a call of its process_request on our
//    stream. The handlers keep registering on it as on any httplib::Server.
//  - ConnectionStream (a loop connection) and serve_in_memory (a request held in
//    memory, for ApiServer::answer): the httplib::Stream that process_request reads
//    and writes.
//  - write_shared: an httplib content provider's write that the loop turns into
//    sendfile/splice from a SharedBody's memfd instead of a copy.
//  - BlockingPool: httplib's ThreadPool, which parked requests run on.
// What still takes httplib's types directly: the handlers (handlers.*, events.cpp)
// and their registration (api_server.cpp) take httplib::Request and Response.
// ListReplay (list_replay.*) answers the plain list without httplib's parsing but
// with its bytes: the heads it replays are httplib's, made through serve_in_memory.
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
// The handlers' per-request context (RequestContext) travels in a thread_local:
// process_request's setup_request callback sees the Request first, but 0.11's
// Request has no field of ours to carry it in.
#pragma once

#include <httplib.h>

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>

namespace rsd::api {

class SharedBody;  // server_loop.hpp
struct Connection;  // connection.hpp

// httplib's request parsing, routing and response writing, run on a request the
// loop has already read.
class RequestServer : public httplib::Server {
 public:
  // httplib stops writing a response body once it believes its server socket
  // closed (svr_sock_ invalid); this server has none of its own, so it carries
  // the listener's. httplib never uses it otherwise here (no listen(), no stop()).
  explicit RequestServer(int listener_fd) { svr_sock_ = listener_fd; }
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
};

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
