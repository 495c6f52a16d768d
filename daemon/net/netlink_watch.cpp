#include "net/netlink_watch.hpp"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <stdexcept>

namespace rsd::net {

NetlinkWatch::NetlinkWatch() {
  fd_ = socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC | SOCK_NONBLOCK, NETLINK_ROUTE);
  if (fd_ < 0) throw std::runtime_error(std::string("cannot open an rtnetlink socket: ") + std::strerror(errno));
  sockaddr_nl addr{};
  addr.nl_family = AF_NETLINK;
  // Links (appear, go, up, down, carrier) and addresses, both families: an IPv6
  // change is read and found to change nothing the domains use.
  addr.nl_groups = RTMGRP_LINK | RTMGRP_IPV4_IFADDR | RTMGRP_IPV6_IFADDR;
  if (bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) {
    const std::string why = std::strerror(errno);
    close(fd_);
    fd_ = -1;
    throw std::runtime_error("cannot listen for network changes (rtnetlink): " + why);
  }
}

NetlinkWatch::~NetlinkWatch() {
  if (fd_ >= 0) close(fd_);
}

bool NetlinkWatch::drain() {
  bool any = false;
  alignas(nlmsghdr) char buf[16384];
  for (;;) {
    const ssize_t n = recv(fd_, buf, sizeof buf, 0);
    if (n > 0) {
      any = true;
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno == ENOBUFS) {  // the kernel dropped messages: something changed
      any = true;
      continue;
    }
    return any;  // EAGAIN: all read
  }
}

std::vector<NetInterface> list_interfaces() {
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) return {};
  std::map<std::string, NetInterface> by_name;
  for (const ifaddrs* a = list; a; a = a->ifa_next) {
    if (!a->ifa_name) continue;
    NetInterface& i = by_name[a->ifa_name];
    i.name = a->ifa_name;
    i.up = a->ifa_flags & IFF_UP;
    i.running = a->ifa_flags & IFF_RUNNING;
    i.loopback = a->ifa_flags & IFF_LOOPBACK;
    i.multicast = a->ifa_flags & IFF_MULTICAST;
    if (a->ifa_addr && a->ifa_addr->sa_family == AF_INET) {
      char text[INET_ADDRSTRLEN] = {};
      inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(a->ifa_addr)->sin_addr, text, sizeof text);
      i.ipv4.emplace_back(text);
    }
  }
  freeifaddrs(list);
  std::vector<NetInterface> out;
  for (auto& [name, i] : by_name) out.push_back(std::move(i));
  return out;
}

}  // namespace rsd::net
