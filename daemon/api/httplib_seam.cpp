// The seam's code (httplib_seam.hpp): httplib's streams over a loop connection and
// over memory, the request context handlers reach through a thread_local, and the
// shared body's write.
#include "api/httplib_seam.hpp"

#include "api/connection.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/uio.h>

namespace rsd::api {

namespace {

thread_local RequestContext* tls_context = nullptr;

// A request held in memory and its answer collected: the offline form of
// ConnectionStream.
class MemoryStream final : public httplib::Stream {
 public:
  explicit MemoryStream(std::string_view in) : in_(in) {}
  std::string out;
  bool is_readable() const override { return pos_ < in_.size(); }
  bool is_writable() const override { return true; }
  ssize_t read(char* ptr, size_t size) override {
    if (pos_ >= in_.size()) return -1;
    const auto n = std::min(size, in_.size() - pos_);
    std::memcpy(ptr, in_.data() + pos_, n);
    pos_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, size_t size) override {
    out.append(ptr, size);
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 40000;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 8035;
  }
  socket_t socket() const override { return -1; }

 private:
  std::string_view in_;
  std::size_t pos_ = 0;
};

}  // namespace

RequestContext* RequestContext::current() { return tls_context; }
void set_request_context(RequestContext* context) { tls_context = context; }

bool ConnectionStream::is_readable() const { return pos_ < c_.http.in().size(); }
bool ConnectionStream::is_writable() const { return !c_.http.out().broken; }
socket_t ConnectionStream::socket() const { return c_.fd; }

ssize_t ConnectionStream::read(char* ptr, size_t size) {
  const std::string& in = c_.http.in();
  if (pos_ >= in.size()) return -1;  // all a request can have arrived already
  const auto n = std::min(size, in.size() - pos_);
  std::memcpy(ptr, in.data() + pos_, n);
  pos_ += n;
  return static_cast<ssize_t>(n);
}

ssize_t ConnectionStream::write(const char* ptr, size_t size) {
  Outbox& o = c_.http.out();
  if (o.broken) return -1;
  // A shared body being written (write_shared): from its memfd, without a copy.
  if (const auto* ctx = RequestContext::current(); ctx && ctx->body && ctx->body->fd() >= 0 && !o.file &&
      ptr == ctx->body->bytes().data() + ctx->body_offset) {
    o.file = ctx->body;
    o.file_offset = ctx->body_offset;
    o.file_left = size;
    if (!send_pending(c_)) return -1;
    return static_cast<ssize_t>(size);
  }
  // Nothing may follow a body still going out of its memfd (it would overtake it);
  // httplib writes nothing after a sized body, so this would be a bug: close.
  if (o.file_left > 0) return -1;
  if (size < kDirectWrite) {
    o.out.append(ptr, size);
    return static_cast<ssize_t>(size);
  }
  // Headers still buffered and this body in one system call; what the socket
  // does not take now is kept for the loop.
  iovec iov[2] = {{o.out.data() + o.out_pos, o.out_pending()}, {const_cast<char*>(ptr), size}};
  msghdr msg{};
  msg.msg_iov = iov;
  msg.msg_iovlen = 2;
  ssize_t n;
  do n = ::sendmsg(c_.fd, &msg, MSG_NOSIGNAL | MSG_DONTWAIT);
  while (n < 0 && errno == EINTR);
  if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
    o.broken = true;
    return -1;
  }
  std::size_t sent = n > 0 ? static_cast<std::size_t>(n) : 0;
  const auto from_out = std::min(sent, o.out_pending());
  o.out_pos += from_out;
  sent -= from_out;
  if (o.out_pending() == 0) {
    o.out.clear();
    o.out_pos = 0;
  }
  o.out.append(ptr + sent, size - sent);
  return static_cast<ssize_t>(size);
}

void ConnectionStream::address(bool local, std::string& ip, int& port) const {
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

std::string serve_in_memory(RequestServer& server, std::string_view request) {
  MemoryStream stream(request);
  bool closed = false;
  server.serve(stream, false, closed);
  return std::move(stream.out);
}

bool write_shared(httplib::DataSink& sink, const std::shared_ptr<const SharedBody>& body, std::size_t offset,
                  std::size_t length) {
  RequestContext* ctx = RequestContext::current();
  if (ctx) {
    ctx->body = body;
    ctx->body_offset = offset;
  }
  const bool ok = sink.write(body->bytes().data() + offset, length);
  if (ctx) ctx->body.reset();
  return ok;
}

}  // namespace rsd::api
