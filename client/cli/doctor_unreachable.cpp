// rs-discover doctor when the daemon cannot be asked: what to do, by the cause (the
// socket's owner and group for a permission error, the HTTP address, starting it).
#include "doctor.hpp"
#include "files.hpp"

// The library's, header-only: the socket's owner is named as its errors name it.
#include "../src/account_names.hpp"

#include <dirent.h>
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <utility>
#include <vector>

namespace rsdiscover::doctor {
namespace {

using rsdiscovery::detail::group_name;
using rsdiscovery::detail::user_name;

// The file that closes `path` to this user: the first directory on the way closed to
// this user, else the socket itself; its owner and group.
std::optional<struct stat> closed_by(const std::string& path) {
  struct stat st {};
  for (auto slash = path.find('/', 1); slash != std::string::npos; slash = path.find('/', slash + 1)) {
    const std::string dir = path.substr(0, slash);
    if (::access(dir.c_str(), X_OK) != 0) return ::stat(dir.c_str(), &st) == 0 ? std::optional(st) : std::nullopt;
  }
  if (::stat(path.c_str(), &st) == 0) return st;
  return std::nullopt;
}

// Whether joining group `gid` would give more than the socket: root's group, the groups
// that administer a Debian system or its devices, or the owner's own (private) group.
bool grants_more(gid_t gid, uid_t owner) {
  static const char* const kSystem[] = {"root", "sudo", "wheel", "adm", "admin", "staff", "disk", "shadow", "kmem",
                                        "sys", "tty", "docker", "lxd", "libvirt", "systemd-journal", "plugdev"};
  const std::string name = group_name(gid);
  if (gid == 0 || std::find(std::begin(kSystem), std::end(kSystem), name) != std::end(kSystem)) return true;
  const passwd* pw = ::getpwuid(owner);
  return pw && owner != 0 && pw->pw_gid == gid;
}

// "http://HOST:PORT" as a client on this host reaches the daemon's "http" value (a
// wildcard address by loopback); "" when it is off.
std::string reachable_http(std::string http) {
  if (http == "off" || http.empty()) return "";
  if (http.rfind("0.0.0.0:", 0) == 0) http = "127.0.0.1:" + http.substr(8);
  if (http.rfind("[::]:", 0) == 0) http = "[::1]:" + http.substr(5);
  return "http://" + http;
}

// The "http" of a config file, when this user may read it.
std::optional<std::string> http_in_file(const std::string& path) {
  const auto text = read_file(path);
  if (!text) return std::nullopt;
  const auto doc = rsdiscovery::json::parse_or_null(without_bom(*text));
  if (const auto http = rsdiscovery::json::text(rsdiscovery::json::find(doc, "http"))) return std::string(*http);
  return std::nullopt;
}

// The HTTP addresses the daemons on this host were given, the one on `socket_path`
// first, then those given no --socket: their command lines (readable by every user,
// unlike their sockets) name --http, or the --config file that does. Then the system
// configuration's, then the default. Candidates only: the caller asks each.
std::vector<std::string> local_http_candidates(const std::string& socket_path) {
  std::vector<std::string> mine, others;
  if (DIR* proc = ::opendir("/proc")) {
    while (const dirent* e = ::readdir(proc)) {
      if (e->d_name[0] < '1' || e->d_name[0] > '9') continue;
      // The arguments, each ended by a NUL.
      const auto cmdline = read_file(std::string("/proc/") + e->d_name + "/cmdline").value_or("");
      std::vector<std::string> argv;
      for (std::size_t at = 0; at < cmdline.size();) {
        const auto end = std::min(cmdline.find('\0', at), cmdline.size());
        argv.push_back(cmdline.substr(at, end - at));
        at = end + 1;
      }
      if (argv.empty() || argv[0].substr(argv[0].rfind('/') + 1) != "rs-discoveryd") continue;
      std::optional<std::string> http, config, socket;
      for (std::size_t i = 1; i < argv.size(); ++i) {
        for (auto [flag, into] : {std::pair{"--http", &http}, {"--config", &config}, {"-c", &config},
                                  {"--socket", &socket}}) {
          const std::string f = flag;
          if (argv[i] == f && i + 1 < argv.size()) *into = argv[i + 1];
          else if (argv[i].rfind(f + "=", 0) == 0) *into = argv[i].substr(f.size() + 1);
        }
      }
      if (!http && config) http = http_in_file(*config);
      if (!http && !config) http = http_in_file("/etc/rs-discoveryd/config.json");
      // A daemon given another socket is not the one asked for; one given none may be on it.
      if (socket && *socket != socket_path) continue;
      (socket ? mine : others).push_back(reachable_http(http.value_or("127.0.0.1:8035")));
    }
    ::closedir(proc);
  }
  mine.insert(mine.end(), others.begin(), others.end());
  mine.push_back(reachable_http(http_in_file("/etc/rs-discoveryd/config.json").value_or("127.0.0.1:8035")));
  std::vector<std::string> out;
  for (const auto& c : mine)
    if (std::find(out.begin(), out.end(), c) == out.end()) out.push_back(c);
  return out;
}

bool answers(const std::string& endpoint) {
  if (endpoint.empty()) return false;
  try {
    rsdiscovery::ClientOptions options;
    options.connect_timeout(std::chrono::milliseconds(1000))
        .request_timeout(std::chrono::milliseconds(2000))
        .complete_timeout(std::chrono::milliseconds(0));
    rsdiscovery::Client(endpoint, options).health();
    return true;
  } catch (const rsdiscovery::Error&) {
    return false;
  }
}

}  // namespace

// What to do when the daemon could not be asked, by the cause: a user without
// rights on the socket must not be told to start a daemon that runs.
std::string unreachable_hint(const rsdiscovery::Error& e, const rsdiscovery::Endpoint& endpoint) {
  // The first address a daemon answers at, else the likeliest one: named either way.
  std::string http;
  bool http_answers = false;
  if (endpoint.kind == rsdiscovery::Endpoint::Kind::unix_socket) {
    const auto candidates = local_http_candidates(endpoint.path);
    for (const auto& c : candidates)
      if (answers(c)) {
        http = c;
        http_answers = true;
        break;
      }
    if (!http_answers && !candidates.empty()) http = candidates.front();
  }
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
    const auto closed = closed_by(endpoint.path);
    if (closed && !grants_more(closed->st_gid, closed->st_uid)) {
      const std::string g = group_name(closed->st_gid);
      out += ": join group " + g + " ('sudo usermod -aG " + g + " " + me + "', then log in again)" +
             (use_http.empty() ? "" : ", or " + use_http);
    } else {
      // Joining that group would give this user far more than the socket.
      if (closed)
        out += "; its group " + group_name(closed->st_gid) + " grants much more than this socket: do not join it";
      out += "; give the socket a group of its own: the packaged service's socket unit does "
             "(SocketGroup=rs-discoveryd, then 'sudo usermod -aG rs-discoveryd " +
             me + "'), as does a systemd socket unit of your own with SocketGroup=, and a daemon "
             "started by hand takes --socket-group GROUP (config key \"socket-group\")";
      if (!use_http.empty()) out += "; or " + use_http;
    }
    return out;
  }
  if (e.code() == rsdiscovery::ErrorCode::not_running && http_answers)
    return "the daemon is not on this socket, but it answers over HTTP: " + use_http;
  if (e.code() == rsdiscovery::ErrorCode::not_running)
    return "start it: 'systemctl start rs-discoveryd', or see 'rs-discoveryd --help'";
  return "";
}

}  // namespace rsdiscover::doctor
