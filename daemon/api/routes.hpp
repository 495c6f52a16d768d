// The API's routes, spelled once: method, path pattern (as proto/openapi.yaml spells
// it), handler and whether it may block. Registration with httplib, 404/405 and
// `Allow`, the known paths and the blocking pool's choice all read this table, and
// tests/api/test_routes_spec.py holds it against the spec.
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <string_view>

namespace rsd::api {

class Handlers;
struct ApiRequest;   // exchange.hpp
struct ApiResponse;  // exchange.hpp

struct Route {
  std::string_view method;   // GET routes also answer HEAD (httplib does)
  // The path as the spec spells it. "{name}" is one path parameter: one or more of
  // any characters but CR and LF, '/' included (a topic-root "realsense/D455_1"
  // names a device too). At most one per pattern.
  std::string_view pattern;
  void (Handlers::*handler)(const ApiRequest&, ApiResponse&);
  // Waits on something outside the daemon (Camera Discovery waits on the camera):
  // served on the blocking pool, never on an event loop that serves everyone else.
  bool blocking = false;
};

// Every route; their order does not matter (see match_route).
std::span<const Route> routes();

// The route that serves the (decoded) `path`, or nothing. Where two patterns match
// ("/v1/devices/x/description" is also a device id "x/description"), the one with
// more literal characters wins.
const Route* match_route(std::string_view path);

// The characters of the pattern outside its parameter: the more, the more specific.
std::size_t literal_length(const Route& route);

// The route's pattern as a std::regex for httplib, its parameter a capture group
// (req.matches[1]); matches exactly the paths match_route() gives it.
std::string route_regex(const Route& route);

// "GET, HEAD" for a routed path; the methods of every route for any other.
std::string allowed_methods(std::string_view path);

// Whether the raw request target (path and query, percent-encoded) goes to the
// blocking pool: it is decoded as httplib decodes it before routing.
bool blocking_target(std::string_view target);

}  // namespace rsd::api
