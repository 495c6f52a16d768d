// The poll every client makes, `GET /v1/devices` with no query, answered without
// httplib: with the head httplib itself wrote for this table generation, learnt
// once per change by running httplib on a canonical request in memory, and the
// list's shared body. Anything else, and any request this does not read exactly
// as httplib would, goes to httplib as before.
//
// Why: with the body sent from its memfd in one splice, what was left of a list
// request's cost in the daemon was httplib's parsing, header maps and response
// writing (11 % of the daemon's CPU in the profile, and its share of libc:
// tolower, snprintf, malloc), which kept the Unix socket at 0.88x nginx with 64
// connections (bench/results/profile-http.txt). The bytes sent stay httplib's:
// the head is replayed, not written here, so no second HTTP writer can drift.
#pragma once

#include "api/server_loop.hpp"

#include <optional>
#include <string_view>

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
struct PlainList {
  std::string_view host;           // "" when none was sent
  std::string_view if_none_match;  // "" when none was sent
  bool close = false;              // `Connection: close`
};
std::optional<PlainList> read_plain_list(std::string_view request);

class ListReplay {
 public:
  // `server` is the listener's httplib server (whose heads are replayed);
  // `host_check` the HTTP listener's, null on the Unix socket. All must outlive it.
  ListReplay(Handlers& handlers, RequestServer& server, bool http, const HostCheck* host_check)
      : handlers_(handlers), server_(server), http_(http), host_check_(host_check) {}

  // ServerLoop's QuickAnswer: true when `request` was answered in `reply`.
  bool answer(std::string_view request, bool stopping, QuickReply& reply);

 private:
  Handlers& handlers_;
  RequestServer& server_;
  const bool http_;
  const HostCheck* const host_check_;
};

}  // namespace rsd::api
