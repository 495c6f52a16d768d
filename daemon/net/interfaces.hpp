// Which of the host's network interfaces the DDS domains are joined on: the
// interfaces as the kernel lists them, the user's rules, and the choice made of
// them. Pure: the netlink watcher (netlink_watch.*) fills the list, unit tests
// make one up.
#pragma once

#include <string>
#include <vector>

namespace rsd::net {

// One interface as the kernel reports it (getifaddrs: flags and addresses).
struct NetInterface {
  std::string name;
  bool up = false;         // IFF_UP: configured up
  bool running = false;    // IFF_RUNNING: the link has carrier
  bool loopback = false;   // IFF_LOOPBACK
  bool multicast = false;  // IFF_MULTICAST: DDS discovery is multicast
  std::vector<std::string> ipv4;  // its IPv4 addresses (Cyclone DDS speaks IPv4 by default)
};

struct InterfaceRules {
  // Names or shell patterns (fnmatch: "eth1", "enp*"); empty: every usable one.
  std::vector<std::string> include;
  // Never joined unless `include` names them: container and VM bridges carry no
  // cameras and come and go with every container started.
  std::vector<std::string> exclude;
};

std::vector<std::string> default_excluded_interfaces();

// The interfaces to join, sorted by name, each with its addresses. An interface is
// usable when it is up, has carrier, is multicast-capable and has an IPv4 address;
// loopback only when `include` names it, or when nothing else is usable (local
// peers still meet). Empty only without loopback: Cyclone DDS then chooses.
std::vector<NetInterface> select_interfaces(const std::vector<NetInterface>& all, const InterfaceRules& rules);

// A Cyclone DDS configuration fragment joining exactly these interfaces; "" for none.
std::string cyclone_interfaces_xml(const std::vector<NetInterface>& chosen);

// Whether a Cyclone DDS configuration (XML text, or file://PATH, whose file is
// read) names its own interfaces: the user's explicit choice, which the daemon
// then leaves alone.
bool cyclone_config_names_interfaces(const std::string& config);

// "eth0 (192.0.2.2), eth1 (10.1.0.5)"; "none" for an empty list.
std::string describe(const std::vector<NetInterface>& chosen);

}  // namespace rsd::net
