// A request and its answer as the route handlers see them: what they read of a
// request and what they decide of its response, with no HTTP library in sight. The
// seam (httplib_seam.*) makes an ApiRequest of httplib's request and writes an
// ApiResponse into httplib's response, so that httplib's types stay in that one file
// and the handlers are plain functions of these two.
#pragma once

#include "api/format.hpp"

#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace rsd::api {

class SharedBody;  // server_loop.hpp
class EventFeed;   // server_loop.hpp

struct ApiRequest {
  std::string method;  // "GET", "HEAD", ...
  std::string path;    // decoded, without the query
  std::string target;  // as sent: path and query, percent-encoded
  QueryParams params;  // decoded, in order
  std::string id;      // the route's {id} parameter, decoded; "" when it has none
  std::vector<std::pair<std::string, std::string>> headers;  // as sent, in order

  // The first header of that name (compared ignoring case), "" when there is none.
  std::string header(std::string_view name) const;
  bool has_header(std::string_view name) const;
  std::string param(std::string_view name) const;  // the first value, "" when none
  bool has_param(std::string_view name) const { return params.find(std::string(name)) != params.end(); }
};

struct ApiResponse {
  int status = 200;
  std::vector<std::pair<std::string, std::string>> headers;
  std::string content_type;  // "" with an empty body: no Content-Type (a 304)
  std::string body;
  // Instead of `body`: bytes shared by many responses, sent from their memfd.
  std::shared_ptr<const SharedBody> shared;
  // Instead of `body`: an SSE stream. The seam writes the head and the feed's first
  // text as the first chunk; then the event loop takes the connection over.
  std::shared_ptr<EventFeed> stream;

  void set_header(std::string name, std::string value) { headers.emplace_back(std::move(name), std::move(value)); }
  void set_content(std::string text, std::string type) {
    body = std::move(text);
    content_type = std::move(type);
  }
};

}  // namespace rsd::api
