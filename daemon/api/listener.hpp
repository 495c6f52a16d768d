// Socket-level help for the API listeners: what cpp-httplib 0.11 does not do
// for us (stale Unix sockets, adopting systemd's fds, ending idle connections).
#pragma once

#include <httplib.h>

#include <sys/socket.h>
#include <unistd.h>

#include <string>

namespace rsd::api {

class Listener : public httplib::Server {
 public:
  // httplib only serves sockets it created itself; systemd hands us sockets that
  // are already bound and listening, so plant the fd where listen_after_bind()
  // expects its own.
  // An adopted socket is polled (idle interval) so that halt() can end the
  // accept loop without shutdown(2).
  void adopt(int fd) {
    svr_sock_ = fd;
    adopted_fd_ = fd;
    set_idle_interval(0, 50000);
  }
  int fd() const { return svr_sock_; }
  // stop(), except for an adopted socket: httplib's stop() shutdown(2)s it, and
  // that socket is shared with systemd, which keeps it listening for the next
  // start: a shut-down socket would refuse every client from then on. The
  // accept loop sees the socket gone within the idle interval; the fd is closed
  // (never shut down) once the Listener goes, after that loop has ended.
  void halt() {
    if (adopted_fd_ < 0) stop();
    else released_fd_ = svr_sock_.exchange(INVALID_SOCKET);
  }
  ~Listener() override {
    if (released_fd_ >= 0) ::close(released_fd_);
  }

 private:
  int adopted_fd_ = -1;
  int released_fd_ = -1;
};

// Makes `path` free for bind(). A socket file left by a crashed daemon (nobody
// accepts on it) is removed; a live one, or a path that is not a socket, is a
// std::runtime_error: we never take over another daemon's socket, and never
// delete a file we don't understand.
void prepare_unix_socket_path(const std::string& path);

// The local address of a socket, to recognise its accepted connections later.
struct SocketAddress {
  sockaddr_storage storage{};
  socklen_t length = 0;
  bool valid() const { return length > 0; }
};
SocketAddress local_address(int fd);

// shutdown(2)s the read side, without closing, of every connected socket of this
// process whose local address is `local`: the connections accepted by that
// listener. Requests already received are still answered.
// httplib 0.11 parks a worker for up to its keep-alive timeout on an idle
// connection and only then notices the server stopped; waking it this way lets
// stop() return at once. Closing is left to httplib, so no fd is closed twice.
// Returns how many connections were shut down.
int shutdown_accepted_connections(const SocketAddress& local);

}  // namespace rsd::api
