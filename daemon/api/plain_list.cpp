// The plain list's reading (read_plain_list) and its answer, with heads written
// once per table generation on each loop thread (plain_list.hpp says why).
#include "api/plain_list.hpp"

#include "api/format.hpp"
#include "api/handlers.hpp"
#include "api/host_check.hpp"
#include "log/log.hpp"

#include <cctype>
#include <memory>

namespace rsd::api {

namespace {

constexpr std::string_view kRequestLine = "GET /v1/devices HTTP/1.1\r\n";

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i]))) return false;
  return true;
}

// RFC 9110's token characters: a header name.
bool is_token(std::string_view s) {
  if (s.empty()) return false;
  for (unsigned char c : s)
    if (!(std::isalnum(c) || std::string_view("!#$%&'*+-.^_`|~").find(static_cast<char>(c)) != std::string_view::npos))
      return false;
  return true;
}

// Visible ASCII, spaces and tabs: nothing httplib could read differently.
bool is_plain_value(std::string_view s) {
  for (unsigned char c : s)
    if (!(c == '\t' || (c >= 0x20 && c < 0x7f))) return false;
  return true;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// The heads for the current body on this thread, by [304][close].
struct Heads {
  const PlainList* owner = nullptr;
  std::shared_ptr<const SharedBody> body;  // held, so that its address names only it
  bool complete = false;
  std::string etag;
  std::array<std::array<std::string, 2>, 2> head;
};
thread_local Heads tls_heads;

// The fields of the answer to `GET /v1/devices?`, in the order httplib sets them:
// handle_devices sets ETag and Cache-Control, the shared body's content provider
// Content-Type; then httplib adds Content-Length, and Connection or Keep-Alive; a
// 304's Content-Length, for a response with no body, comes last. A field that
// handle_devices or into_httplib adds must be added here too (the tests compare
// the bytes).
std::vector<HeadField> list_fields(bool not_modified, bool close, std::string_view etag, std::string_view length,
                                   std::string_view keep_alive) {
  std::vector<HeadField> fields{{"ETag", etag}, {"Cache-Control", "no-cache"}};
  if (!not_modified) {
    fields.push_back({"Content-Type", kJson});
    fields.push_back({"Content-Length", length});
  }
  fields.push_back(close ? HeadField{"Connection", "close"} : HeadField{"Keep-Alive", keep_alive});
  if (not_modified) fields.push_back({"Content-Length", "0"});
  return fields;
}

}  // namespace

std::optional<PlainListRequest> read_plain_list(std::string_view request) {
  if (!request.starts_with(kRequestLine)) return std::nullopt;
  std::string_view rest = request.substr(kRequestLine.size());
  PlainListRequest out;
  bool seen[6] = {};
  for (;;) {
    const auto eol = rest.find("\r\n");
    if (eol == std::string_view::npos) return std::nullopt;
    const auto line = rest.substr(0, eol);
    rest.remove_prefix(eol + 2);
    if (line.empty()) break;
    const auto colon = line.find(':');
    if (colon == std::string_view::npos) return std::nullopt;
    const auto name = line.substr(0, colon);
    const auto value = trim(line.substr(colon + 1));
    if (!is_token(name) || !is_plain_value(value)) return std::nullopt;
    int which;
    if (iequals(name, "host")) which = 0;
    else if (iequals(name, "user-agent")) which = 1;
    else if (iequals(name, "accept")) which = 2;
    else if (iequals(name, "connection")) which = 3;
    else if (iequals(name, "if-none-match")) which = 4;
    else if (iequals(name, "accept-encoding")) which = 5;
    else return std::nullopt;
    if (seen[which]) return std::nullopt;
    seen[which] = true;
    if (which == 0) out.host = value;
    if (which == 4) out.if_none_match = value;
    // Only "identity" (what the project's own clients and Python's http.client
    // send): any other may have httplib compress the body.
    if (which == 5 && value != "identity") return std::nullopt;
    if (which == 3) {
      // httplib closes on exactly "close"; any other value is left to it.
      if (value == "close") out.close = true;
      else if (value != "keep-alive" && value != "Keep-Alive") return std::nullopt;
    }
  }
  if (!rest.empty()) return std::nullopt;  // a body (the scan counted one) or a second request
  return out;
}

PlainList::PlainList(Handlers& handlers, const RequestServer& server, const HostCheck* host_check)
    : handlers_(handlers), host_check_(host_check), keep_alive_(server.keep_alive_value()) {
  for (int not_modified = 0; not_modified < 2; ++not_modified)
    for (int close = 0; close < 2; ++close) {
      std::vector<std::string_view> names;
      for (const auto& f : list_fields(not_modified, close, "", "", "")) names.push_back(f.name);
      order_[not_modified][close] = field_order(names);
    }
}

std::string PlainList::head(bool not_modified, bool close, std::string_view etag, std::size_t length) const {
  const std::string size = std::to_string(length);
  const auto fields = list_fields(not_modified, close, etag, size, keep_alive_);
  std::vector<HeadField> ordered;
  ordered.reserve(fields.size());
  for (const std::size_t i : order_[not_modified][close]) ordered.push_back(fields[i]);
  return response_head(not_modified ? 304 : 200, ordered);
}

bool PlainList::answer(std::string_view request, bool stopping, QuickReply& reply) {
  const auto plain = read_plain_list(request);
  if (!plain) return false;
  if (host_check_ && !host_check_->allows(plain->host)) return false;  // httplib's 421
  // As handle_devices: completeness first, then the list.
  const bool done = handlers_.status.discovery_complete();
  std::uint64_t generation = 0;
  auto body = handlers_.device_list(DeviceFilter{}, DeviceFields{}, std::string(), done, generation);
  Heads& h = tls_heads;
  if (h.owner != this || h.body != body || h.complete != done) {
    h.etag = list_etag(generation, done);
    for (int not_modified = 0; not_modified < 2; ++not_modified)
      for (int close = 0; close < 2; ++close)
        h.head[not_modified][close] = head(not_modified, close, h.etag, body->bytes().size());
    h.owner = this;
    h.body = body;
    h.complete = done;
  }
  const bool not_modified = etag_matches(plain->if_none_match, h.etag);
  const bool close = plain->close || stopping;
  reply.head = h.head[not_modified][close];
  reply.body = not_modified ? nullptr : std::move(body);
  reply.close = close;
  const int status = not_modified ? 304 : 200;
  ++handlers_.requests_by_status[static_cast<std::size_t>(status)];
  if (log::enabled(log::Level::debug))
    log::debug("api: GET /v1/devices -> " + std::to_string(status) + " (plain list)");
  return true;
}

}  // namespace rsd::api
