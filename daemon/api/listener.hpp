// The API's listening sockets: binding them (Unix socket with its stale-file
// rule, TCP) before the server loop takes them over.
#pragma once

#include <sys/socket.h>

#include <string>

namespace rsd::api {

// Makes `path` free for bind(). A socket file left by a crashed daemon (nobody
// accepts on it) is removed; a live one, or a path that is not a socket, is a
// std::runtime_error: we never take over another daemon's socket, and never
// delete a file we don't understand.
void prepare_unix_socket_path(const std::string& path);

// A listening Unix socket at `path`, mode 0660 from the start, of group `gid` unless
// it is -1. Throws std::runtime_error with a message fit for the user.
int listen_unix(const std::string& path, int gid = -1);

// A listening TCP socket on host:port (port 0: any free one; the host may be a
// name, an IPv4 or an IPv6 address, with or without brackets). SO_REUSEADDR
// only: a quick restart works, a second daemon on the same port does not.
// Throws std::runtime_error with a message fit for the user.
int listen_tcp(const std::string& host, int port);

// The TCP port `fd` is bound to (0 if none).
int bound_port(int fd);
// The address `fd` is bound to, as text ("127.0.0.1", "::1"); "" if none.
std::string bound_address(int fd);
// Whether `fd` is bound to the wildcard address (0.0.0.0 or ::).
bool bound_to_any(int fd);
// Whether `fd` is bound to a loopback address (127/8, ::1).
bool bound_to_loopback(int fd);

}  // namespace rsd::api
