// Listening sockets handed over by systemd (socket activation): which one is the
// API's Unix socket and which the HTTP port.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace rsd::service {

enum class SocketRole { unix_api, http, unusable };

// What a passed fd is for. Its FileDescriptorName= decides when it is "unix" or
// "http"; any other name (systemd's default is the socket unit's name, and
// `systemd-socket-activate` without --fdname says "unknown") leaves it to the
// socket's family: AF_UNIX is the Unix API, AF_INET/AF_INET6 is HTTP. Either way
// it has to be a listening stream socket of a fitting family, else `why` says
// what is wrong and the role is `unusable`.
SocketRole classify_socket(int fd, const std::string& name, std::string& why);

struct ListenSockets {
  int unix_fd = -1;   // -1: none passed; bind the configured path
  int http_fd = -1;   // -1: none passed; bind the configured HOST:PORT
  bool activated = false;  // systemd passed any fds at all
  std::vector<std::string> notes;  // what was taken or left, for the log
};

// Takes the fds of LISTEN_FDS/LISTEN_FDNAMES (sd_listen_fds_with_names) and
// clears those variables. A passed fd that is neither (or a second one of a
// role) is closed and noted; a socket named "unix" or "http" whose kind does not
// fit is a configuration error: std::runtime_error.
ListenSockets take_listen_sockets();

}  // namespace rsd::service
