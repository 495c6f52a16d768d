// Where the daemon's Unix socket is when nothing names one: the one rule the daemon
// (daemon/config) and the C++ client use. The Python package spells the same rule in
// Python (it has no C++ in it); tests/client checks that the three agree.
#pragma once

#include <string>

namespace rsd::model {

// The daemon's HTTP port when the configuration names none, and so the port a
// client assumes for an endpoint given as a bare host ("--endpoint camera-pc").
inline constexpr int kDefaultHttpPort = 8035;

// The system service's socket (systemd's RuntimeDirectory=rs-discoveryd).
inline constexpr const char* kSystemSocket = "/run/rs-discoveryd/api.sock";

// $RUNTIME_DIRECTORY/api.sock (its first entry) when set; else kSystemSocket for root;
// else $XDG_RUNTIME_DIR/rs-discoveryd.sock; else /tmp/rs-discoveryd-UID.sock (a user
// without a runtime directory, e.g. over su or in a container). Empty strings count as
// unset.
std::string default_socket_path(const char* runtime_directory, const char* xdg_runtime_dir,
                                unsigned euid);
// The same, from this process' environment and effective uid.
std::string default_socket_path();

}  // namespace rsd::model
