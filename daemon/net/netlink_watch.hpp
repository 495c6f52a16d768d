// The kernel's word that the host's network changed: an rtnetlink socket joined
// to the link and address groups (as Avahi's netlink.c does), read by the main
// loop when it is readable. What changed is not parsed: any message means "list
// the interfaces again" (getifaddrs, itself a netlink dump), and a choice that
// did not change costs nothing further (NetworkFollower).
#pragma once

#include "net/interfaces.hpp"

#include <string>
#include <vector>

namespace rsd::net {

class NetlinkWatch {
 public:
  // Opens and binds the socket; throws std::runtime_error when it cannot.
  NetlinkWatch();
  ~NetlinkWatch();
  NetlinkWatch(const NetlinkWatch&) = delete;
  NetlinkWatch& operator=(const NetlinkWatch&) = delete;

  int fd() const { return fd_; }
  // Reads every pending message; true if any arrived (or the kernel dropped
  // some for a full buffer, which also means "list again").
  bool drain();

 private:
  int fd_ = -1;
};

// The host's interfaces now, with their flags and IPv4 addresses.
std::vector<NetInterface> list_interfaces();

}  // namespace rsd::net
