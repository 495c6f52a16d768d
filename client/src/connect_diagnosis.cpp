// Why connecting to the daemon failed, said for a user: tried once more with a plain
// socket, the error (no socket, a stale one, permission denied with the socket's
// owner and group, nothing listening on the port) becomes an Error saying what to do.
#include "internal.hpp"

#include "account_names.hpp"

#include <netdb.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace rsdiscovery::detail {

namespace {

std::string hint() {
  return "is rs-discoveryd running? Give another endpoint with --endpoint or "
         "RS_DISCOVERY_ENDPOINT";
}

Error unix_error(const std::string& path, int err) {
  switch (err) {
    case ENOENT:
    case ENOTDIR:
      return Error(ErrorCode::not_running,
                   "cannot reach rs-discoveryd: no socket at " + path + " (" + hint() + ")");
    case ECONNREFUSED:
      return Error(ErrorCode::not_running, "cannot reach rs-discoveryd: nothing listens on " +
                                               path + " (a stale socket file; " + hint() + ")");
    case EACCES:
    case EPERM: {
      std::string msg = "permission denied on " + path;
      struct stat st {};
      if (::stat(path.c_str(), &st) == 0) {
        char mode[8];
        std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
        msg += " (owned by " + user_name(st.st_uid) + ":" + group_name(st.st_gid) + ", mode " +
               mode + "; this user is " + user_name(geteuid()) + ": join group " +
               group_name(st.st_gid) + " or ask the administrator)";
      } else {
        msg += " (a directory on the way to it is not accessible to this user)";
      }
      return Error(ErrorCode::permission_denied, msg);
    }
    default:
      return Error(ErrorCode::not_running,
                   "cannot reach rs-discoveryd at " + path + ": " + std::strerror(err));
  }
}

}  // namespace

Error diagnose_connect(const Endpoint& endpoint) {
  if (endpoint.kind == Endpoint::Kind::unix_socket) {
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (endpoint.path.size() >= sizeof addr.sun_path)
      return Error(ErrorCode::bad_endpoint, "socket path too long: " + endpoint.path);
    std::memcpy(addr.sun_path, endpoint.path.c_str(), endpoint.path.size() + 1);
    int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return unix_error(endpoint.path, errno);
    int rc = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    int err = errno;
    ::close(fd);
    if (rc == 0)  // it answers now: it was busy or restarting
      return Error(ErrorCode::not_running,
                   "rs-discoveryd at " + endpoint.path + " closed the connection");
    return unix_error(endpoint.path, err);
  }
  std::string where = endpoint.to_string();
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  int gai = ::getaddrinfo(endpoint.host.c_str(), std::to_string(endpoint.port).c_str(), &hints, &res);
  if (gai != 0)
    return Error(ErrorCode::not_running, "cannot resolve " + endpoint.host + ": " + gai_strerror(gai));
  int err = ECONNREFUSED;
  for (addrinfo* ai = res; ai; ai = ai->ai_next) {
    int fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
    if (fd < 0) continue;
    int rc = ::connect(fd, ai->ai_addr, ai->ai_addrlen);
    err = rc == 0 ? 0 : errno;
    ::close(fd);
    if (rc == 0) break;
  }
  ::freeaddrinfo(res);
  if (err == 0)
    return Error(ErrorCode::not_running, "rs-discoveryd at " + where + " closed the connection");
  if (err == ECONNREFUSED)
    return Error(ErrorCode::not_running,
                 "cannot reach rs-discoveryd: nothing listens on " + where + " (" + hint() + ")");
  return Error(ErrorCode::not_running,
               "cannot reach rs-discoveryd at " + where + ": " + std::strerror(err));
}

}  // namespace rsdiscovery::detail
