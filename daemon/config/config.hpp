// The daemon's configuration: embedded defaults, then the JSON config file, then
// command-line flags (flags win), validated into one plain struct.
#pragma once

#include "rsd_model/expected.hpp"
#include "rsd_model/socket_path.hpp"

#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace rsd {

using model::kDefaultHttpPort;
inline constexpr const char* kDefaultConfigFile = "/etc/rs-discoveryd/config.json";
inline constexpr int kMaxDomain = 232;  // RTPS port mapping ends there

struct Config {
  std::vector<int> domains{0};
  std::string socket_path;  // "" : no Unix socket
  // The group the Unix socket is given (mode 0660), so its users join a group that
  // grants the socket and nothing else; "": the daemon's own. -1 with it.
  std::string socket_group;
  int socket_gid = -1;
  std::string http_host = "127.0.0.1";  // "" : no HTTP
  int http_port = kDefaultHttpPort;
  // The file or a flag named the HTTP address (or turned it off). Under socket
  // activation the socket unit's address wins; one named here that differs from it
  // is reported (log, /healthz "http", rs-discover doctor), the default is not.
  bool http_set = false;
  bool usb = true;
  // Announce this host's USB cameras on every domain (rs-discoveryd/shared-usb) so
  // other hosts' daemons list them; off by default: it tells the network what is
  // plugged in here. Other hosts' shared cameras are listed either way.
  bool share_usb = false;
  std::string participant_name = "rs-discoveryd";
  std::string log_level = "info";
  std::string cyclonedds_config;  // XML fragment or file URI, passed to every domain
  // The network interfaces the domains join: names or shell patterns ("eth1",
  // "enp*"); empty: every usable one. The excluded ones are never joined unless
  // `interfaces` names them (container and VM bridges by default).
  std::vector<std::string> interfaces;
  std::vector<std::string> exclude_interfaces = {"docker*", "veth*", "virbr*", "br-*", "lxcbr*",
                                                 "lxdbr*", "podman*", "cni*", "flannel*", "vnet*"};
  // Caps against floods: a realdds server announces a handful of devices.
  std::size_t max_devices_per_participant = 128;
  std::size_t max_devices_per_domain = 1024;
  // Device-info writers followed, against a host matching thousands of them.
  std::size_t max_writers_per_participant = 256;
  std::size_t max_writers_per_domain = 2048;
  // Camera Discovery: how long fetching one device's description may take
  // (seconds; the use case's limit is 30).
  int describe_timeout_s = 30;
  // Describe the devices of these domains as they appear (all: every domain).
  bool describe_eagerly_all = false;
  std::vector<int> describe_eagerly;
  // A DDS camera whose server's lease ran out stays listed, `unresponsive`, this long
  // (seconds; 0: removed at once, as librealsense does).
  int removal_grace_s = 0;
  // HTTP answers these Host names besides localhost and its own address ("*": any).
  std::vector<std::string> allowed_hosts;
  // API clients at once, over both listeners; beyond, a 503 with Retry-After.
  std::size_t max_clients = 4096;
  // The cameras this host is built with (a robot's, a rig's): /v1/expected, /healthz,
  // /metrics and STATUS= say which of them are listed. Empty: none expected.
  std::vector<model::ExpectedCamera> expect;
  std::string config_file;        // where the file part came from ("" : none)
};

// check_config: --check-config [FILE], read and validate the configuration, then exit.
enum class CommandAction { run, help, version, check_config };

struct CommandLine {
  CommandAction action = CommandAction::run;
  Config config;
};

// $RUNTIME_DIRECTORY/api.sock (systemd), else /run/rs-discoveryd/api.sock for
// root, else $XDG_RUNTIME_DIR/rs-discoveryd.sock (or /tmp/rs-discoveryd-UID.sock).
std::string default_socket_path();

// Reads flags, then the config file they name (or the default one, if it exists),
// and merges them. Throws ConfigError with a message fit for the user.
CommandLine parse_command_line(int argc, const char* const* argv);

// Applies a config document (the file's text) onto `config`. Throws ConfigError.
void apply_config_json(const std::string& text, Config& config);

struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

const char* usage_text();

}  // namespace rsd
