// cpp-httplib's view of a loop connection (ConnectionStream: the request from the
// loop's buffer, the response into the connection's output), the request context
// httplib's handlers reach through a thread_local, and write_shared. With
// RequestServer (server_loop.hpp) this is the daemon's seam to cpp-httplib's
// request processing.
#include "api/connection.hpp"
#include "api/connection_stream.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>


namespace rsd::api {

namespace {

thread_local RequestContext* tls_context = nullptr;

}  // namespace

RequestContext* RequestContext::current() { return tls_context; }
void set_request_context(RequestContext* context) { tls_context = context; }

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
