// The transport's sockets: connecting within a timeout, reads and writes until a
// deadline, each wait in slices so that a cancel is seen without a wake-up of its own.
#include "socket_io.hpp"

#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace rsdiscovery::detail {

int open_socket(const Endpoint& endpoint, std::chrono::milliseconds timeout) {
  auto connect_with_timeout = [&](int fd, const sockaddr* addr, socklen_t len) {
    if (::connect(fd, addr, len) == 0) return true;
    if (errno != EINPROGRESS && errno != EAGAIN) return false;
    pollfd p{fd, POLLOUT, 0};
    if (::poll(&p, 1, static_cast<int>(timeout.count())) != 1) return false;
    int err = 0;
    socklen_t n = sizeof err;
    return ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &n) == 0 && err == 0;
  };
  if (endpoint.kind == Endpoint::Kind::unix_socket) {
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (endpoint.path.size() >= sizeof addr.sun_path) return -1;
    std::memcpy(addr.sun_path, endpoint.path.c_str(), endpoint.path.size() + 1);
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd >= 0 && connect_with_timeout(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr)) return fd;
    if (fd >= 0) ::close(fd);
    return -1;
  }
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  if (::getaddrinfo(endpoint.host.c_str(), std::to_string(endpoint.port).c_str(), &hints, &res) != 0) return -1;
  int fd = -1;
  for (addrinfo* ai = res; ai && fd < 0; ai = ai->ai_next) {
    fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, ai->ai_protocol);
    if (fd < 0) continue;
    if (!connect_with_timeout(fd, ai->ai_addr, ai->ai_addrlen)) {
      ::close(fd);
      fd = -1;
    }
  }
  ::freeaddrinfo(res);
  if (fd >= 0) {
    int yes = 1;  // a request goes out whole, at once
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
  }
  return fd;
}

namespace {

using Clock = std::chrono::steady_clock;

// Waits for the socket to be readable (or writable) until `deadline`.
IoEnd wait_for(int fd, short events, Deadline deadline, const std::atomic<bool>& cancelled) {
  for (;;) {
    if (cancelled) return IoEnd::cancelled;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return IoEnd::timeout;
    pollfd p{fd, events, 0};
    // A slice at most, so that cancel() is seen without a wake-up of its own.
    const int rc = ::poll(&p, 1, static_cast<int>(std::min<long long>(left, 100)));
    if (rc > 0) return IoEnd::ok;
    if (rc < 0 && errno != EINTR) return IoEnd::failed;
  }
}

}  // namespace

IoEnd write_all(int fd, std::string_view data, Deadline deadline, const std::atomic<bool>& cancelled) {
  while (!data.empty()) {
    const ssize_t n = ::send(fd, data.data(), data.size(), MSG_NOSIGNAL);
    if (n > 0) {
      data.remove_prefix(static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      if (const auto w = wait_for(fd, POLLOUT, deadline, cancelled); w != IoEnd::ok) return w;
      continue;
    }
    return IoEnd::closed;
  }
  return IoEnd::ok;
}

IoEnd read_some(int fd, std::string& buffer, Deadline deadline, const std::atomic<bool>& cancelled) {
  // Straight into the buffer, no copy on the way: into the room it has (all of a body
  // whose length is known, once reserved), at least a page and at most 64 KiB. A
  // first read of a page and then the body's length reserved touches fewer fresh
  // pages than a larger first read would, which a cold one-shot process pays for.
  const std::size_t had = buffer.size();
  const std::size_t room = std::clamp<std::size_t>(buffer.capacity() - had, 4096, 65536);
  buffer.resize(had + room);  // zeroes it: std::string cannot grow uninitialised before C++23
  for (;;) {
    const ssize_t n = ::recv(fd, buffer.data() + had, room, 0);
    if (n > 0) {
      buffer.resize(had + static_cast<std::size_t>(n));
      return IoEnd::ok;
    }
    IoEnd end = IoEnd::closed;
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      end = wait_for(fd, POLLIN, deadline, cancelled);
      if (end == IoEnd::ok) continue;
    }
    buffer.resize(had);
    return end;
  }
}

}  // namespace rsdiscovery::detail
