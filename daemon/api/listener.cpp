#include "api/listener.hpp"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include <dirent.h>
#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

namespace rsd::api {

void prepare_unix_socket_path(const std::string& path) {
  sockaddr_un addr{};
  if (path.empty() || path.size() >= sizeof addr.sun_path)
    throw std::runtime_error("unix socket path '" + path + "' is empty or longer than " +
                             std::to_string(sizeof addr.sun_path - 1) + " bytes");
  struct stat st{};
  if (lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return;
    throw std::runtime_error("cannot use unix socket path '" + path + "': " + std::strerror(errno));
  }
  if (!S_ISSOCK(st.st_mode))
    throw std::runtime_error("'" + path + "' exists and is not a socket; not replacing it");

  int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(std::string("socket(AF_UNIX): ") + std::strerror(errno));
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int rc = connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  const int err = errno;
  close(fd);
  if (rc == 0)
    throw std::runtime_error("another process is serving on unix socket '" + path +
                             "' (is rs-discoveryd already running?)");
  // ECONNREFUSED: the file outlived its listener (a crash). Anything else (e.g.
  // EACCES) means we cannot tell, so leave it alone.
  if (err != ECONNREFUSED)
    throw std::runtime_error("cannot probe existing unix socket '" + path + "': " + std::strerror(err));
  if (unlink(path.c_str()) != 0 && errno != ENOENT)
    throw std::runtime_error("cannot remove stale unix socket '" + path + "': " + std::strerror(errno));
}

int listen_unix(const std::string& path, int gid) {
  prepare_unix_socket_path(path);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(std::string("socket(AF_UNIX): ") + std::strerror(errno));
  // Created 0660 from the start (umask), not chmod-ed after a window in which
  // anyone could connect; chmod then fixes group write if the umask was stricter.
  const mode_t old = umask(0117);
  const int rc = bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  const int err = errno;
  umask(old);
  if (rc != 0 || listen(fd, SOMAXCONN) != 0) {
    const int e = rc != 0 ? err : errno;
    close(fd);
    throw std::runtime_error("cannot listen on unix socket '" + path + "': " + std::strerror(e));
  }
  chmod(path.c_str(), 0660);
  // Before anyone is told the socket is there (READY=1 comes later): until then its
  // group is the daemon's, which only keeps the new group's members out a moment.
  if (gid >= 0 && chown(path.c_str(), static_cast<uid_t>(-1), static_cast<gid_t>(gid)) != 0) {
    const int e = errno;
    close(fd);
    unlink(path.c_str());
    throw std::runtime_error("cannot give unix socket '" + path + "' the group " + std::to_string(gid) + ": " +
                             std::strerror(e) + " (a daemon not run as root must be a member of it)");
  }
  return fd;
}

int listen_tcp(const std::string& host_in, int port) {
  std::string host = host_in;
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string where = "http " + host_in + ":" + std::to_string(port);
  if (const int rc = getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found); rc != 0)
    throw std::runtime_error("cannot listen on " + where + ": " + gai_strerror(rc));
  int last_error = 0;
  for (const addrinfo* ai = found; ai; ai = ai->ai_next) {
    const int fd = socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC, ai->ai_protocol);
    if (fd < 0) {
      last_error = errno;
      continue;
    }
    int yes = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    // Accepted sockets inherit TCP_NODELAY from the listener on Linux: responses
    // go out whole, without waiting for the client's delayed ACK.
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
    if (bind(fd, ai->ai_addr, ai->ai_addrlen) == 0 && listen(fd, SOMAXCONN) == 0) {
      freeaddrinfo(found);
      return fd;
    }
    last_error = errno;
    close(fd);
  }
  freeaddrinfo(found);
  throw std::runtime_error("cannot listen on " + where + ": " +
                           (last_error ? std::strerror(last_error) : "address not usable"));
}

namespace {

bool local_name(int fd, sockaddr_storage& ss) {
  socklen_t len = sizeof ss;
  return fd >= 0 && getsockname(fd, reinterpret_cast<sockaddr*>(&ss), &len) == 0;
}

}  // namespace

int bound_port(int fd) {
  sockaddr_storage ss{};
  if (!local_name(fd, ss)) return 0;
  if (ss.ss_family == AF_INET) return ntohs(reinterpret_cast<const sockaddr_in&>(ss).sin_port);
  if (ss.ss_family == AF_INET6) return ntohs(reinterpret_cast<const sockaddr_in6&>(ss).sin6_port);
  return 0;
}

std::string bound_address(int fd) {
  sockaddr_storage ss{};
  if (!local_name(fd, ss)) return {};
  char buf[INET6_ADDRSTRLEN] = {};
  if (ss.ss_family == AF_INET) inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in&>(ss).sin_addr, buf, sizeof buf);
  else if (ss.ss_family == AF_INET6)
    inet_ntop(AF_INET6, &reinterpret_cast<const sockaddr_in6&>(ss).sin6_addr, buf, sizeof buf);
  return buf;
}

bool bound_to_any(int fd) {
  sockaddr_storage ss{};
  if (!local_name(fd, ss)) return false;
  if (ss.ss_family == AF_INET) return reinterpret_cast<const sockaddr_in&>(ss).sin_addr.s_addr == htonl(INADDR_ANY);
  if (ss.ss_family == AF_INET6) return IN6_IS_ADDR_UNSPECIFIED(&reinterpret_cast<const sockaddr_in6&>(ss).sin6_addr);
  return false;
}

bool bound_to_loopback(int fd) {
  sockaddr_storage ss{};
  if (!local_name(fd, ss)) return false;
  if (ss.ss_family == AF_INET)
    return (ntohl(reinterpret_cast<const sockaddr_in&>(ss).sin_addr.s_addr) >> 24) == 127;
  if (ss.ss_family == AF_INET6) {
    const auto& a = reinterpret_cast<const sockaddr_in6&>(ss).sin6_addr;
    return IN6_IS_ADDR_LOOPBACK(&a) ||
           (IN6_IS_ADDR_V4MAPPED(&a) && a.s6_addr[12] == 127);
  }
  return false;
}

}  // namespace rsd::api
