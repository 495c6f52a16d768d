// Config -> the options of the daemon's parts (daemon_options.hpp).
#include "config/daemon_options.hpp"

#include <chrono>
#include <cstdlib>

namespace rsd {

DaemonOptions daemon_options(const Config& config, std::string_view cyclone_uri) {
  DaemonOptions out;
  log::parse_level(config.log_level, out.log_level);  // validated with the Config
  out.domains = config.domains;
  out.usb = config.usb;
  out.expected = config.expect;

  auto& session = out.session;
  session.participant_name = config.participant_name;
  session.cyclone_config = config.cyclonedds_config;
  session.book.max_devices_per_participant = config.max_devices_per_participant;
  session.book.max_devices_per_domain = config.max_devices_per_domain;
  session.book.max_writers_per_participant = config.max_writers_per_participant;
  session.book.max_writers_per_domain = config.max_writers_per_domain;
  session.describe_timeout = std::chrono::seconds(config.describe_timeout_s);
  session.book.removal_grace = std::chrono::seconds(config.removal_grace_s);
  session.describe_eagerly = config.describe_eagerly_all;
  session.describe_eagerly_in = {config.describe_eagerly.begin(), config.describe_eagerly.end()};
  session.share.share = config.share_usb;
  // An explicit choice of interfaces in the Cyclone configuration (the option, else
  // CYCLONEDDS_URI) is the user's: the daemon then neither chooses nor follows.
  session.interfaces_from_cyclone_config = net::cyclone_config_names_interfaces(
      !config.cyclonedds_config.empty() ? config.cyclonedds_config : std::string(cyclone_uri));

  out.interfaces = {config.interfaces, config.exclude_interfaces};

  auto& api = out.api;
  api.unix_socket = config.socket_path;
  api.unix_socket_gid = config.socket_gid;
  api.http_host = config.http_host;
  api.http_port = config.http_port;
  api.http_configured = config.http_set;
  api.allowed_hosts = config.allowed_hosts;
  api.max_connections = config.max_clients;
  return out;
}

DaemonOptions daemon_options(const Config& config) {
  const char* uri = std::getenv("CYCLONEDDS_URI");
  return daemon_options(config, uri ? uri : "");
}

}  // namespace rsd
