// The poll every client makes, `GET /v1/devices` with no query, answered without
// httplib: a head the daemon writes itself (response_head, the writer of the loop's
// own refusals), made once per table generation on each loop thread, and the list's
// shared body. Anything else, and any request this does not read exactly as httplib
// would, goes to httplib as before.
//
// Why: with the body sent from its memfd in one splice, what was left of a list
// request's cost in the daemon was httplib's parsing, header maps and response
// writing, and its share of libc (tolower, snprintf, malloc): the most frequent
// request paid for a general HTTP server it does not need. The head is the one
// httplib writes for the same request (`GET /v1/devices?`), field for field and in
// its order, so what clients parse does not depend on which path answered;
// test_plain_list.py holds the two to the same bytes.
#pragma once

#include "api/http_connection.hpp"
#include "api/server_loop.hpp"

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::api {

class Handlers;
class HostCheck;

// What a plain list request says, when it is one: the request line exactly
// `GET /v1/devices HTTP/1.1`, CRLF line ends, and only headers that change nothing
// httplib does (Host, User-Agent, Accept, Connection, If-None-Match, and
// Accept-Encoding: identity), each at most once, in visible ASCII. Anything else is
// not a plain list (nullopt): a query, a body, another version, another
// Accept-Encoding (httplib may compress), Range, folded or odd bytes. Pure: the unit
// tests drive it.
struct PlainListRequest {
  std::string_view host;           // "" when none was sent
  std::string_view if_none_match;  // "" when none was sent
  bool close = false;              // `Connection: close`
};
std::optional<PlainListRequest> read_plain_list(std::string_view request);

// The plain list's answer on one listener.
class PlainList {
 public:
  // `server` is the listener's httplib server (whose Keep-Alive value and field
  // order the heads follow); `host_check` the HTTP listener's, null on the Unix
  // socket. All must outlive it.
  PlainList(Handlers& handlers, const RequestServer& server, const HostCheck* host_check);

  // ServerLoop's QuickAnswer: true when `request` was answered in `reply`.
  bool answer(std::string_view request, bool stopping, QuickReply& reply);

  // The head of a 200 (`not_modified` false, `length` the body's bytes) or a 304,
  // for a list tagged `etag`, closing the connection or keeping it.
  std::string head(bool not_modified, bool close, std::string_view etag, std::size_t length) const;

 private:
  Handlers& handlers_;
  const HostCheck* const host_check_;
  const std::string keep_alive_;  // the Keep-Alive value httplib writes
  // By [304][close]: the order httplib writes the fields in (field_order).
  std::array<std::array<std::vector<std::size_t>, 2>, 2> order_;
};

}  // namespace rsd::api
