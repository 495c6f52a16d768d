// Follows the host's network for the DDS domains: chooses the interfaces to join
// (net/interfaces), hears the kernel's changes (net/netlink_watch), decides when
// a change is worth joining anew (net/network_follower) and has DomainSet do it.
// Main thread only: the main loop polls fd() and calls readable() and tick().
#pragma once

#include "net/interfaces.hpp"
#include "net/netlink_watch.hpp"
#include "net/network_follower.hpp"
#include "service/domain_set.hpp"

#include <chrono>
#include <memory>
#include <optional>
#include <vector>

namespace rsd::service {

class NetworkWatch {
 public:
  using Clock = std::chrono::steady_clock;

  // `rules`: the user's choice. `follow` false: the Cyclone configuration names
  // its own interfaces, so nothing is chosen or followed here. Made before the
  // domains are joined: they join on chosen().
  NetworkWatch(DomainSet& domains, net::InterfaceRules rules, bool follow);

  // The interfaces to join the domains on at start (before DomainSet::start).
  const std::vector<net::NetInterface>& chosen() const { return follower_.joined(); }

  int fd() const { return watch_ ? watch_->fd() : -1; }
  // fd() is readable: the kernel reported changes.
  void readable(Clock::time_point now);
  // Joins the domains anew when a change is due; how soon to be called again.
  Clock::duration tick(Clock::time_point now);
  // A reload changed the rules: judged like a change of the network.
  void apply(net::InterfaceRules rules, Clock::time_point now);

 private:
  DomainSet& domains_;
  net::InterfaceRules rules_;
  bool follow_;
  std::unique_ptr<net::NetlinkWatch> watch_;
  net::NetworkFollower follower_;
};

}  // namespace rsd::service
