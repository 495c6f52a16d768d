// rs-discover doctor when the daemon cannot be asked: what to do, by the cause (the
// socket's owner and group for a permission error, the HTTP address, starting it).
#include "doctor.hpp"

// The library's, header-only: the socket's owner is named as its errors name it.
#include "../src/account_names.hpp"

#include <nlohmann/json.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <fstream>

namespace rsdiscover::doctor {
namespace {

using rsdiscovery::detail::group_name;
using rsdiscovery::detail::user_name;

// The group that opens `path` to this user: that of the first directory on the way
// closed to this user, else the socket's own.
std::optional<std::string> group_to_join(const std::string& path) {
  struct stat st {};
  for (auto slash = path.find('/', 1); slash != std::string::npos; slash = path.find('/', slash + 1)) {
    const std::string dir = path.substr(0, slash);
    if (::access(dir.c_str(), X_OK) != 0) return ::stat(dir.c_str(), &st) == 0 ? std::optional(group_name(st.st_gid))
                                                                               : std::nullopt;
  }
  if (::stat(path.c_str(), &st) == 0) return group_name(st.st_gid);
  return std::nullopt;
}

// The daemon's HTTP address, as a client on this host reaches it: the system
// configuration's "http" (when this user may read it), else the default; "" when
// it is off.
std::string local_http_endpoint() {
  std::string http = "127.0.0.1:8035";
  std::ifstream file("/etc/rs-discoveryd/config.json");
  if (file) {
    const auto doc = nlohmann::json::parse(file, nullptr, false);
    if (doc.is_object() && doc.contains("http") && doc["http"].is_string()) http = doc["http"].get<std::string>();
  }
  if (http == "off" || http.empty()) return "";
  if (http.rfind("0.0.0.0:", 0) == 0) http = "127.0.0.1:" + http.substr(8);
  if (http.rfind("[::]:", 0) == 0) http = "[::1]:" + http.substr(5);
  return "http://" + http;
}

bool answers(const std::string& endpoint) {
  if (endpoint.empty()) return false;
  try {
    rsdiscovery::ClientOptions options;
    options.connect_timeout = std::chrono::milliseconds(1000);
    options.request_timeout = std::chrono::milliseconds(2000);
    options.complete_timeout = std::chrono::milliseconds(0);
    rsdiscovery::Client(endpoint, options).health();
    return true;
  } catch (const rsdiscovery::Error&) {
    return false;
  }
}

}  // namespace

// What to do when the daemon could not be asked: by the cause (issue 23: a user
// without rights on the socket was told to start a daemon that runs).
std::string unreachable_hint(const rsdiscovery::Error& e, const rsdiscovery::Endpoint& endpoint) {
  const std::string http = endpoint.kind == rsdiscovery::Endpoint::Kind::unix_socket ? local_http_endpoint() : "";
  const bool http_answers = answers(http);
  const std::string use_http =
      http.empty() ? std::string()
                   : "ask over HTTP, which every user of this host may: 'rs-discover --endpoint " + http + " doctor'" +
                         (http_answers ? " (it answers there)"
                                       : " (the address is the daemon's \"http\" setting; it does not answer at " +
                                             http + " now)");
  if (e.code() == rsdiscovery::ErrorCode::permission_denied && endpoint.kind == rsdiscovery::Endpoint::Kind::unix_socket) {
    // Said here whole, not after the library's message (which names the group too).
    const std::string me = user_name(geteuid());
    std::string out = "permission denied on " + endpoint.path;
    if (struct stat st {}; ::stat(endpoint.path.c_str(), &st) == 0) {
      char mode[8];
      std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
      out += " (owned by " + user_name(st.st_uid) + ":" + group_name(st.st_gid) + ", mode " + mode + ")";
    }
    out += ": the daemon runs, but this user (" + me + ") may not use its socket";
    if (const auto g = group_to_join(endpoint.path))
      out += ": join group " + *g + " ('sudo usermod -aG " + *g + " " + me + "', then log in again)" +
             (use_http.empty() ? "" : ", or " + use_http);
    else if (!use_http.empty())
      out += ": " + use_http;
    return out;
  }
  if (e.code() == rsdiscovery::ErrorCode::not_running && http_answers)
    return "the daemon is not on this socket, but it answers over HTTP: " + use_http;
  if (e.code() == rsdiscovery::ErrorCode::not_running)
    return "start it: 'systemctl start rs-discoveryd', or see 'rs-discoveryd --help'";
  return "";
}

}  // namespace rsdiscover::doctor
