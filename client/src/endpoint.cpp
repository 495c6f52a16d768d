// Where the daemon is: endpoint strings, the environment, the daemon's default path.
#include "internal.hpp"

#include "rsd_model/socket_path.hpp"

#include <unistd.h>

#include <cstdlib>

namespace rsdiscovery {

namespace {

const char* env(const char* name) {
  const char* value = std::getenv(name);
  return value && *value ? value : nullptr;
}

[[noreturn]] void bad(const std::string& text, const std::string& why) {
  throw Error(ErrorCode::bad_endpoint,
              "bad endpoint '" + text + "': " + why +
                  " (expected unix:/path/to/socket or http://host:port)");
}

}  // namespace

Endpoint Endpoint::parse(const std::string& text) {
  Endpoint ep;
  if (text.rfind("unix:", 0) == 0 || (!text.empty() && text[0] == '/')) {
    std::string path = text[0] == '/' ? text : text.substr(5);
    if (path.rfind("//", 0) == 0) path = path.substr(2);  // unix:///run/x.sock
    if (path.empty() || path[0] != '/') bad(text, "the socket path must be absolute");
    ep.kind = Kind::unix_socket;
    ep.path = path;
    return ep;
  }
  if (text.rfind("https://", 0) == 0) bad(text, "https is not supported; the daemon serves plain HTTP");
  // host, host:port, [v6]:port with no scheme: the daemon's HTTP, on its default
  // port when none is given; http://host keeps URL rules (port 80).
  const bool bare = text.find("://") == std::string::npos;
  if (!bare && text.rfind("http://", 0) != 0) bad(text, "unknown scheme");
  std::string rest = bare ? text : text.substr(7);
  if (auto slash = rest.find('/'); slash != std::string::npos) {
    if (rest.find_first_not_of('/', slash) != std::string::npos)
      bad(text, "a path after host:port is not supported");
    rest.resize(slash);
  }
  std::string host, port;
  if (!rest.empty() && rest[0] == '[') {  // [::1]:8035
    auto close = rest.find(']');
    if (close == std::string::npos) bad(text, "unclosed '['");
    host = rest.substr(1, close - 1);
    if (close + 1 < rest.size()) {
      if (rest[close + 1] != ':') bad(text, "junk after ']'");
      port = rest.substr(close + 2);
    }
  } else {
    auto colon = rest.rfind(':');
    host = rest.substr(0, colon);
    if (colon != std::string::npos) port = rest.substr(colon + 1);
  }
  if (host.empty()) bad(text, "no host");
  ep.kind = Kind::http;
  ep.host = host;
  ep.port = bare ? rsd::model::kDefaultHttpPort : 80;
  if (!port.empty()) {
    if (port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos)
      bad(text, "the port is not a number");
    ep.port = std::stoi(port);
    if (ep.port < 1 || ep.port > 65535) bad(text, "the port is out of range");
  }
  return ep;
}

Endpoint Endpoint::default_socket() {
  using rsd::model::kSystemSocket;
  Endpoint ep;
  ep.kind = Kind::unix_socket;
  ep.path = rsd::model::default_socket_path();  // the daemon's own rule
  // A user with no daemon of their own asks the system's (the service runs as its own
  // user; members of its group may use its socket).
  if (!env("RUNTIME_DIRECTORY") && ep.path != kSystemSocket && access(ep.path.c_str(), F_OK) != 0 &&
      access(kSystemSocket, F_OK) == 0)
    ep.path = kSystemSocket;
  return ep;
}

Endpoint Endpoint::from_environment() {
  if (const char* text = env("RS_DISCOVERY_ENDPOINT")) {
    try {
      return parse(text);
    } catch (const Error& e) {  // say where the bad value came from
      throw Error(e.code(), std::string("RS_DISCOVERY_ENDPOINT: ") + e.what());
    }
  }
  return default_socket();
}

std::string Endpoint::to_string() const {
  if (kind == Kind::unix_socket) return "unix:" + path;
  bool v6 = host.find(':') != std::string::npos;
  return "http://" + (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

}  // namespace rsdiscovery
