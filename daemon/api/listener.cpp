#include "api/listener.hpp"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include <dirent.h>
#include <netinet/in.h>
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

SocketAddress local_address(int fd) {
  SocketAddress out;
  socklen_t len = sizeof out.storage;
  if (fd >= 0 && getsockname(fd, reinterpret_cast<sockaddr*>(&out.storage), &len) == 0) out.length = len;
  return out;
}

namespace {

bool same_address(const SocketAddress& a, const SocketAddress& b) {
  if (!a.valid() || !b.valid() || a.storage.ss_family != b.storage.ss_family) return false;
  if (a.storage.ss_family == AF_UNIX) {
    // Accepted Unix connections report the listener's path as their own name.
    const auto& ua = reinterpret_cast<const sockaddr_un&>(a.storage);
    const auto& ub = reinterpret_cast<const sockaddr_un&>(b.storage);
    const auto na = a.length - offsetof(sockaddr_un, sun_path);
    const auto nb = b.length - offsetof(sockaddr_un, sun_path);
    return na > 0 && na == nb && std::memcmp(ua.sun_path, ub.sun_path, na) == 0;
  }
  // A listener on the wildcard address accepts on whichever address was dialled,
  // so for it only the port has to agree. `b` is the listener.
  if (a.storage.ss_family == AF_INET) {
    const auto& ia = reinterpret_cast<const sockaddr_in&>(a.storage);
    const auto& ib = reinterpret_cast<const sockaddr_in&>(b.storage);
    return ia.sin_port == ib.sin_port &&
           (ib.sin_addr.s_addr == htonl(INADDR_ANY) || ia.sin_addr.s_addr == ib.sin_addr.s_addr);
  }
  if (a.storage.ss_family == AF_INET6) {
    const auto& ia = reinterpret_cast<const sockaddr_in6&>(a.storage);
    const auto& ib = reinterpret_cast<const sockaddr_in6&>(b.storage);
    return ia.sin6_port == ib.sin6_port &&
           (IN6_IS_ADDR_UNSPECIFIED(&ib.sin6_addr) ||
            std::memcmp(&ia.sin6_addr, &ib.sin6_addr, sizeof ia.sin6_addr) == 0);
  }
  return false;
}

}  // namespace

int shutdown_accepted_connections(const SocketAddress& local) {
  if (!local.valid()) return 0;
  DIR* dir = opendir("/proc/self/fd");
  if (!dir) return 0;
  const int dir_fd = dirfd(dir);
  int count = 0;
  while (const dirent* entry = readdir(dir)) {
    char* end = nullptr;
    const long n = std::strtol(entry->d_name, &end, 10);
    if (end == entry->d_name || *end != '\0' || n == dir_fd) continue;
    const int fd = static_cast<int>(n);
    struct stat st{};
    if (fstat(fd, &st) != 0 || !S_ISSOCK(st.st_mode)) continue;
    int listening = 0;
    socklen_t optlen = sizeof listening;
    if (getsockopt(fd, SOL_SOCKET, SO_ACCEPTCONN, &listening, &optlen) != 0 || listening) continue;
    if (!same_address(local_address(fd), local)) continue;
    // The read side only: a worker idle on the connection sees end-of-file and
    // lets go, while a request already received (or still in the socket's
    // buffer) is read, answered and written out in full. SHUT_RDWR cut those
    // (a client saw an empty reply during a package upgrade, 1 in ~500).
    if (shutdown(fd, SHUT_RD) == 0) ++count;
  }
  closedir(dir);
  return count;
}

}  // namespace rsd::api
