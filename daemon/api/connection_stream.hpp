// cpp-httplib's view of a loop connection: the request from the loop's buffer,
// the response into the connection's output (large bodies straight to the socket,
// a shared body from its memfd). Internal to daemon/api.
#pragma once

#include "api/connection.hpp"

#include <cstring>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/uio.h>

namespace rsd::api {

class ConnectionStream final : public httplib::Stream {
 public:
  explicit ConnectionStream(Connection& c) : c_(c), in_(c.http.in()), o_(c.http.out()) {}
  std::size_t consumed() const { return pos_; }

  bool is_readable() const override { return pos_ < in_.size(); }
  bool is_writable() const override { return !o_.broken; }
  ssize_t read(char* ptr, size_t size) override {
    if (pos_ >= in_.size()) return -1;  // all a request can have arrived already
    const auto n = std::min(size, in_.size() - pos_);
    std::memcpy(ptr, in_.data() + pos_, n);
    pos_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, size_t size) override {
    if (o_.broken) return -1;
    // A shared body being written (write_shared): from its memfd, without a copy.
    if (const auto* ctx = RequestContext::current(); ctx && ctx->body && ctx->body->fd() >= 0 && !o_.file &&
        ptr == ctx->body->bytes().data() + ctx->body_offset) {
      o_.file = ctx->body;
      o_.file_offset = ctx->body_offset;
      o_.file_left = size;
      if (!send_pending(c_)) return -1;
      return static_cast<ssize_t>(size);
    }
    // Nothing may follow a body still going out of its memfd (it would overtake it);
    // httplib writes nothing after a sized body, so this would be a bug: close.
    if (o_.file_left > 0) return -1;
    if (size < kDirectWrite) {
      o_.out.append(ptr, size);
      return static_cast<ssize_t>(size);
    }
    // Headers still buffered and this body in one system call; what the socket
    // does not take now is kept for the loop.
    iovec iov[2] = {{o_.out.data() + o_.out_pos, o_.out_pending()}, {const_cast<char*>(ptr), size}};
    msghdr msg{};
    msg.msg_iov = iov;
    msg.msg_iovlen = 2;
    ssize_t n;
    do n = ::sendmsg(c_.fd, &msg, MSG_NOSIGNAL | MSG_DONTWAIT);
    while (n < 0 && errno == EINTR);
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
      o_.broken = true;
      return -1;
    }
    std::size_t sent = n > 0 ? static_cast<std::size_t>(n) : 0;
    const auto from_out = std::min(sent, o_.out_pending());
    o_.out_pos += from_out;
    sent -= from_out;
    if (o_.out_pending() == 0) {
      o_.out.clear();
      o_.out_pos = 0;
    }
    o_.out.append(ptr + sent, size - sent);
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override { address(false, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address(true, ip, port); }
  socket_t socket() const override { return c_.fd; }

 private:
  void address(bool local, std::string& ip, int& port) const {
    auto& a = local ? c_.local : c_.remote;
    if (!a.known) {
      a.known = true;
      sockaddr_storage ss{};
      socklen_t len = sizeof ss;
      const int rc = local ? getsockname(c_.fd, reinterpret_cast<sockaddr*>(&ss), &len)
                           : getpeername(c_.fd, reinterpret_cast<sockaddr*>(&ss), &len);
      char buf[INET6_ADDRSTRLEN] = {};
      if (rc == 0 && ss.ss_family == AF_INET) {
        const auto& in = reinterpret_cast<const sockaddr_in&>(ss);
        inet_ntop(AF_INET, &in.sin_addr, buf, sizeof buf);
        a.port = ntohs(in.sin_port);
      } else if (rc == 0 && ss.ss_family == AF_INET6) {
        const auto& in = reinterpret_cast<const sockaddr_in6&>(ss);
        inet_ntop(AF_INET6, &in.sin6_addr, buf, sizeof buf);
        a.port = ntohs(in.sin6_port);
      }
      a.ip = buf;
    }
    ip = a.ip;
    port = a.port;
  }

  Connection& c_;
  const std::string& in_;
  Outbox& o_;
  std::size_t pos_ = 0;
};

}  // namespace rsd::api
