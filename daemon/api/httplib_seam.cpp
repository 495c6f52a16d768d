// The seam's code (httplib_seam.hpp): httplib's streams over a loop connection and
// over memory, the request context handlers reach through a thread_local, and the
// shared body's write.
#include "api/httplib_seam.hpp"

#include "api/connection.hpp"
#include "api/routes.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <exception>
#include <vector>

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

ApiRequest api_request(const httplib::Request& req) {
  ApiRequest out;
  out.method = req.method;
  out.path = req.path;
  out.target = req.target;
  out.params = QueryParams(req.params.begin(), req.params.end());
  if (req.matches.size() > 1) out.id = req.matches[1].str();
  out.headers.assign(req.headers.begin(), req.headers.end());
  return out;
}

// `api` into httplib's response: the same calls the handlers made on httplib's
// types before, so the bytes written are as they were.
void into_httplib(ApiResponse&& api, httplib::Response& res) {
  res.status = api.status;
  for (auto& [name, value] : api.headers) res.set_header(name, value);
  if (api.stream) {
    // httplib writes the head and this first chunk; then the loop takes the
    // connection over (RequestContext::adopt_as_stream) and feeds it.
    res.set_chunked_content_provider(api.content_type, [feed = std::move(api.stream)](std::size_t, httplib::DataSink& sink) {
      auto* context = RequestContext::current();
      const auto first = feed->poll(Clock::now());
      if (!context || !sink.write(first.data(), first.size())) return false;
      context->adopt_as_stream = feed;
      return false;  // httplib stops here and writes nothing more
    });
  } else if (api.shared) {
    const auto size = api.shared->bytes().size();
    res.set_content_provider(size, api.content_type,
                             [body = std::move(api.shared)](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                               return write_shared(sink, body, offset, length);
                             });
  } else if (!api.body.empty() || !api.content_type.empty()) {
    res.set_content(std::move(api.body), api.content_type);
  }
}

// Runs `handle` on the API's view of `req` and writes its answer into `res`.
template <typename Handle>
void answer(const httplib::Request& req, httplib::Response& res, Handle&& handle) {
  ApiResponse api;
  api.status = res.status;
  handle(api_request(req), api);
  into_httplib(std::move(api), res);
}

}  // namespace

void RequestServer::install(std::span<const Route> routes, const ServerRules& rules) {
  set_payload_max_length(rules.max_payload);
  // Only what httplib writes in its Keep-Alive header: the loop decides when a
  // connection ends (ServerLoop's idle timeout).
  constexpr int kKeepAliveMax = 100000;
  const int keep_alive_timeout = std::max(1, rules.keep_alive_timeout_s);
  set_keep_alive_max_count(kKeepAliveMax);
  set_keep_alive_timeout(keep_alive_timeout);
  // As httplib spells it (write_response_core).
  keep_alive_value_ = "timeout=" + std::to_string(keep_alive_timeout) + ", max=" + std::to_string(kKeepAliveMax);

  // httplib takes the first pattern that matches: the most literal first, so that
  // ".../description" is not taken for a device id (match_route's rule).
  std::vector<const Route*> by_literal;
  for (const auto& route : routes) by_literal.push_back(&route);
  std::stable_sort(by_literal.begin(), by_literal.end(),
                   [](const Route* a, const Route* b) { return literal_length(*a) > literal_length(*b); });
  for (const Route* route : by_literal)
    if (route->method == "GET")
      Get(route_regex(*route), [rules, route](const httplib::Request& req, httplib::Response& res) {
        answer(req, res, [&](const ApiRequest& r, ApiResponse& a) { rules.dispatch(*route, r, a); });
      });

  // Other methods are registered as plain handlers so httplib reads (and bounds)
  // the body first and the connection stays in step.
  auto not_allowed = [rules](const httplib::Request& req, httplib::Response& res) {
    answer(req, res, rules.not_allowed);
  };
  // httplib 0.11 answers 400 to a POST/PUT/PATCH/DELETE that has no body headers at
  // all (it expects one) before any route runs; with no body there is nothing to
  // read, so such requests are answered here, before that check.
  set_pre_routing_handler([rules](const httplib::Request& req, httplib::Response& res) {
    ApiResponse api;
    auto request = api_request(req);
    if (rules.guard && rules.guard(request, api)) {
      into_httplib(std::move(api), res);
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.method == "GET" || req.method == "HEAD" || req.has_header("Content-Length") ||
        req.has_header("Transfer-Encoding"))
      return httplib::Server::HandlerResponse::Unhandled;
    rules.not_allowed(request, api);
    into_httplib(std::move(api), res);
    return httplib::Server::HandlerResponse::Handled;
  });
  Post(".*", not_allowed);
  Put(".*", not_allowed);
  Patch(".*", not_allowed);
  Delete(".*", not_allowed);
  Options(".*", not_allowed);

  set_error_handler(httplib::Server::HandlerWithResponse([rules](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
    answer(req, res, rules.on_error);
    return httplib::Server::HandlerResponse::Handled;
  }));
  set_exception_handler([rules](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
    std::string what = "unknown error";
    try {
      if (ep) std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    answer(req, res, [&](const ApiRequest& r, ApiResponse& a) { rules.on_exception(r, a, what); });
  });
  set_logger([rules](const httplib::Request& req, const httplib::Response& res) {
    rules.answered(req.method, req.target, res.status);
  });
}

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

std::vector<std::size_t> field_order(std::span<const std::string_view> names) {
  httplib::Headers headers;
  for (std::size_t i = 0; i < names.size(); ++i) headers.emplace(std::string(names[i]), std::to_string(i));
  std::vector<std::size_t> order;
  for (const auto& [name, index] : headers) order.push_back(std::stoul(index));
  return order;
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
