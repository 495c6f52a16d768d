// cpp-httplib's view of a loop connection (ConnectionStream: the request from the
// loop's buffer, the response into the connection's output), the request context
// httplib's handlers reach through a thread_local, and the loop's own canned
// responses. With RequestServer (server_loop.hpp) this is the daemon's seam to
// cpp-httplib's request processing.
#include "api/connection.hpp"
#include "api/connection_stream.hpp"
#include "api/format.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>


namespace rsd::api {

namespace {

thread_local RequestContext* tls_context = nullptr;

}  // namespace

RequestContext* RequestContext::current() { return tls_context; }
void set_request_context(RequestContext* context) { tls_context = context; }

std::string canned_response(int status, const std::string& message, bool retry_after) {
  const std::string body = error_body(status, message);
  std::string out = "HTTP/1.1 " + std::to_string(status) + " " + std::string(status_text(status)) + "\r\n";
  out += "Content-Type: application/json\r\n";
  if (retry_after) out += "Retry-After: 1\r\n";
  out += "Connection: close\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
  return out;
}

std::string chunk(const std::string& data) {
  char size[32];
  std::snprintf(size, sizeof size, "%zx\r\n", data.size());
  return size + data + "\r\n";
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
