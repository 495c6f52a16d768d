// The route table and its matcher. The matcher is plain string work, not a regex: the
// server loop asks blocking_target() for every request before httplib parses it.
#include "api/routes.hpp"

#include "api/handlers.hpp"

#include <array>
#include <set>

namespace rsd::api {

namespace {

// The paths of proto/openapi.yaml, and the page and the spec themselves.
const std::array<Route, 14> kRoutes = {{
    {"GET", "/v1/devices", &Handlers::handle_devices},
    {"GET", "/v1/devices/{id}", &Handlers::handle_device},
    {"GET", "/v1/devices/{id}/description", &Handlers::handle_description, true},
    {"GET", "/v1/devices/{id}/clients", &Handlers::handle_clients},
    {"GET", "/v1/devices/{id}/history", &Handlers::handle_device_history},
    {"GET", "/v1/history", &Handlers::handle_history},
    {"GET", "/v1/events", &Handlers::handle_events},
    {"GET", "/v1/domains", &Handlers::handle_domains},
    {"GET", "/v1/participants", &Handlers::handle_participants},
    {"GET", "/v1/expected", &Handlers::handle_expected},
    {"GET", "/healthz", &Handlers::handle_health},
    {"GET", "/metrics", &Handlers::handle_metrics},
    {"GET", "/", &Handlers::handle_page},
    {"GET", "/openapi.yaml", &Handlers::handle_spec},
}};

// A pattern cut at its parameter: `prefix` and `suffix` when it has one, else the
// whole pattern in `prefix`.
struct Parts {
  std::string_view prefix, suffix;
  bool parameter = false;
};

Parts parts(std::string_view pattern) {
  const auto open = pattern.find('{');
  if (open == std::string_view::npos) return {pattern, {}, false};
  const auto close = pattern.find('}', open);
  return {pattern.substr(0, open), pattern.substr(close + 1), true};
}

bool matches(const Route& route, std::string_view path) {
  const auto p = parts(route.pattern);
  if (!p.parameter) return path == p.prefix;
  if (path.size() <= p.prefix.size() + p.suffix.size()) return false;  // the parameter is never empty
  if (!path.starts_with(p.prefix) || !path.ends_with(p.suffix)) return false;
  const auto value = path.substr(p.prefix.size(), path.size() - p.prefix.size() - p.suffix.size());
  // std::regex's '.' (route_regex) takes neither.
  return value.find_first_of("\r\n") == std::string_view::npos;
}

int hex(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// %XX as httplib decodes a path before routing ('+' stays); a malformed escape stays
// as it is. (httplib's %uXXXX form never makes a route's literal characters.)
std::string decode_path(std::string_view in) {
  std::string out;
  out.reserve(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    if (in[i] == '%' && i + 2 < in.size() && hex(in[i + 1]) >= 0 && hex(in[i + 2]) >= 0) {
      out.push_back(static_cast<char>(hex(in[i + 1]) * 16 + hex(in[i + 2])));
      i += 2;
    } else {
      out.push_back(in[i]);
    }
  }
  return out;
}

}  // namespace

std::span<const Route> routes() { return kRoutes; }

std::size_t literal_length(const Route& route) {
  const auto p = parts(route.pattern);
  return p.prefix.size() + p.suffix.size();
}

const Route* match_route(std::string_view path) {
  const Route* best = nullptr;
  for (const auto& route : kRoutes)
    if (matches(route, path) && (!best || literal_length(route) > literal_length(*best))) best = &route;
  return best;
}

std::string route_regex(const Route& route) {
  auto escape = [](std::string_view literal) {
    std::string out;
    for (char c : literal) {
      if (std::string_view(R"(\^$.|?*+()[]{})").find(c) != std::string_view::npos) out.push_back('\\');
      out.push_back(c);
    }
    return out;
  };
  const auto p = parts(route.pattern);
  return p.parameter ? escape(p.prefix) + "(.+)" + escape(p.suffix) : escape(p.prefix);
}

std::string allowed_methods(std::string_view path) {
  std::set<std::string_view> methods;
  const Route* routed = match_route(path);
  for (const auto& route : kRoutes)
    if (!routed || route.pattern == routed->pattern) methods.insert(route.method);
  std::string out;
  for (auto m : methods) {
    out += (out.empty() ? "" : ", ") + std::string(m);
    if (m == "GET") out += ", HEAD";
  }
  return out;
}

bool blocking_target(std::string_view target) {
  const Route* route = match_route(decode_path(target.substr(0, target.find('?'))));
  return route && route->blocking;
}

}  // namespace rsd::api
