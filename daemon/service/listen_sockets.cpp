#include "service/listen_sockets.hpp"

#include <systemd/sd-daemon.h>

#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>

namespace rsd::service {

namespace {

bool is_listening_stream(int fd, int family) { return sd_is_socket(fd, family, SOCK_STREAM, 1) > 0; }

bool is_tcp_listener(int fd) { return is_listening_stream(fd, AF_INET) || is_listening_stream(fd, AF_INET6); }

}  // namespace

SocketRole classify_socket(int fd, const std::string& name, std::string& why) {
  const std::string what = "fd " + std::to_string(fd) + " (name '" + name + "')";
  if (name == "unix") {
    if (is_listening_stream(fd, AF_UNIX)) return SocketRole::unix_api;
    why = what + " is named for the Unix API but is not a listening AF_UNIX stream socket";
    return SocketRole::unusable;
  }
  if (name == "http") {
    if (is_tcp_listener(fd)) return SocketRole::http;
    why = what + " is named for HTTP but is not a listening TCP socket";
    return SocketRole::unusable;
  }
  if (is_listening_stream(fd, AF_UNIX)) return SocketRole::unix_api;
  if (is_tcp_listener(fd)) return SocketRole::http;
  why = what + " is not a listening Unix or TCP stream socket";
  return SocketRole::unusable;
}

ListenSockets take_listen_sockets() {
  ListenSockets out;
  char** names = nullptr;
  const int n = sd_listen_fds_with_names(1, &names);
  if (n < 0) {
    // LISTEN_PID not ours, or malformed variables: not activated.
    std::free(names);
    return out;
  }
  out.activated = n > 0;
  std::string error;
  for (int i = 0; i < n; ++i) {
    const int fd = SD_LISTEN_FDS_START + i;
    const std::string name = names && names[i] ? names[i] : "unknown";
    std::string why;
    const SocketRole role = classify_socket(fd, name, why);
    int* slot = role == SocketRole::unix_api ? &out.unix_fd : role == SocketRole::http ? &out.http_fd : nullptr;
    if (slot && *slot < 0) {
      *slot = fd;
      out.notes.push_back(std::string("using the ") + (role == SocketRole::unix_api ? "Unix" : "HTTP") +
                          " socket systemd passed as fd " + std::to_string(fd) + " ('" + name + "')");
      continue;
    }
    if (slot) why = "fd " + std::to_string(fd) + " ('" + name + "') is a second socket of the same kind";
    // A socket explicitly named for a role that it cannot serve is a unit bug
    // worth failing for; anything else is closed and the rest goes on.
    if (!slot && (name == "unix" || name == "http")) {
      if (error.empty()) error = why;
    } else {
      out.notes.push_back("closing " + why);
    }
    close(fd);
  }
  if (names) {
    for (int i = 0; i < n; ++i) std::free(names[i]);
    std::free(names);
  }
  if (!error.empty()) {
    if (out.unix_fd >= 0) close(out.unix_fd);
    if (out.http_fd >= 0) close(out.http_fd);
    throw std::runtime_error("systemd passed an unusable socket: " + error);
  }
  return out;
}

}  // namespace rsd::service
