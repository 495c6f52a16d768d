// What the daemon's parts are made with, from the one Config: the one place a
// Config field becomes a part's option. main() makes the parts with it;
// Service::reload applies its live part (config_keys says which keys are live).
// A target of its own (rsd_daemon_options): it knows the parts' option types, and
// rsd_config, which every part may read, must not.
#pragma once

#include "api/api_server.hpp"
#include "config/config.hpp"
#include "dds/domain_session.hpp"
#include "log/log.hpp"
#include "net/interfaces.hpp"

#include <string_view>
#include <vector>

namespace rsd {

struct DaemonOptions {
  log::Level log_level = log::Level::info;
  std::vector<int> domains;
  bool usb = true;
  // Every domain's session (DomainSet sets `domain`); its describe_timeout is also
  // how long an API request waits for a description (DomainsAndUsbStatus).
  dds::SessionOptions session;
  // The interfaces the domains join (NetworkWatch); not followed when the Cyclone
  // configuration names its own (session.interfaces_from_cyclone_config).
  net::InterfaceRules interfaces;
  // The listeners and their limits; the sockets systemd passes are main()'s to add.
  api::ApiOptions api;
  // The cameras this host is built with (Service hands them to its ExpectedSet).
  std::vector<model::ExpectedCamera> expected;
};

// `cyclone_uri` stands for $CYCLONEDDS_URI, which counts where the configuration
// has no cyclonedds-config of its own; the one-argument form reads it.
DaemonOptions daemon_options(const Config& config, std::string_view cyclone_uri);
DaemonOptions daemon_options(const Config& config);

}  // namespace rsd
