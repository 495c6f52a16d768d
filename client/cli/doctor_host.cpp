// rs-discover doctor's view of this host's network: its IPv4 interfaces, the route
// discovery multicast leaves by, and the kinds of address no camera is reached at.
#include "doctor.hpp"
#include "files.hpp"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <net/if.h>

#include <algorithm>
#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

namespace rsdiscover::doctor {

std::vector<Interface> ipv4_interfaces() {
  std::vector<Interface> out;
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) return out;
  for (ifaddrs* i = list; i; i = i->ifa_next) {
    if (!i->ifa_addr || i->ifa_addr->sa_family != AF_INET || !i->ifa_netmask) continue;
    Interface itf;
    itf.name = i->ifa_name;
    itf.address = reinterpret_cast<sockaddr_in*>(i->ifa_addr)->sin_addr;
    itf.netmask = reinterpret_cast<sockaddr_in*>(i->ifa_netmask)->sin_addr;
    itf.up = (i->ifa_flags & IFF_UP) && (i->ifa_flags & IFF_RUNNING);
    itf.multicast = i->ifa_flags & IFF_MULTICAST;
    itf.loopback = i->ifa_flags & IFF_LOOPBACK;
    out.push_back(itf);
  }
  freeifaddrs(list);
  return out;
}

std::string text_of(in_addr a) {
  char buf[INET_ADDRSTRLEN] = "";
  inet_ntop(AF_INET, &a, buf, sizeof buf);
  return buf;
}

std::optional<in_addr> ipv4(const std::string& text) {
  in_addr a{};
  if (inet_pton(AF_INET, text.c_str(), &a) != 1) return std::nullopt;
  return a;
}

bool same_subnet(const Interface& itf, in_addr other) {
  return (itf.address.s_addr & itf.netmask.s_addr) == (other.s_addr & itf.netmask.s_addr);
}

// The interface the kernel would send 239.255.0.1 (Cyclone's discovery group) out
// of: a route covering it (224.0.0.0/4 and the like) or the default route; "" when
// there is none. From /proc/net/route (the main table, as `ip route` shows it).
std::string multicast_route() {
  const std::string routes = read_file("/proc/net/route").value_or("");
  std::string best;
  int best_bits = -1;
  const std::uint32_t group = htonl(0xEFFF0001);  // 239.255.0.1, as the file has it (network order)
  // After the header, a line a route: Iface Destination Gateway Flags RefCnt Use
  // Metric Mask ..., separated by blanks.
  bool header = true;
  for (std::size_t at = 0; at < routes.size();) {
    const auto end = std::min(routes.find('\n', at), routes.size());
    const std::string_view line(routes.data() + at, end - at);
    at = end + 1;
    if (std::exchange(header, false)) continue;
    std::vector<std::string> fields;
    for (std::size_t i = 0; i < line.size() && fields.size() < 8;) {
      const auto start = line.find_first_not_of(" \t", i);
      if (start == std::string_view::npos) break;
      const auto stop = std::min(line.find_first_of(" \t", start), line.size());
      fields.emplace_back(line.substr(start, stop - start));
      i = stop;
    }
    if (fields.size() < 8) continue;
    const std::string &iface = fields[0], &dest_hex = fields[1], &flags_hex = fields[3], &mask_hex = fields[7];
    const auto dest = static_cast<std::uint32_t>(std::stoul(dest_hex, nullptr, 16));
    const auto mask = static_cast<std::uint32_t>(std::stoul(mask_hex, nullptr, 16));
    const auto flags = std::stoul(flags_hex, nullptr, 16);
    if (!(flags & 0x1)) continue;  // RTF_UP
    if ((group & mask) != (dest & mask)) continue;
    const int bits = __builtin_popcount(mask);
    if (bits > best_bits) {
      best_bits = bits;
      best = iface;
    }
  }
  return best;
}

bool link_local(in_addr a) { return (ntohl(a.s_addr) >> 16) == 0xA9FE; }  // 169.254/16
// Docker's and Podman's default bridges: a camera there is behind NAT, out of reach
// of multicast discovery from the host's network.
bool container_bridge(in_addr a) {
  const auto h = ntohl(a.s_addr);
  return (h >> 16) == 0xAC11 || (h >> 16) == 0x0A58;  // 172.17/16, 10.88/16
}

bool endpoint_is_local(const std::string& endpoint) {
  if (endpoint.rfind("unix:", 0) == 0 || (!endpoint.empty() && endpoint[0] == '/')) return true;
  for (const char* host : {"127.", "localhost", "[::1]"})
    if (endpoint.find(std::string("://") + host) != std::string::npos || endpoint.rfind(host, 0) == 0) return true;
  return false;
}

}  // namespace rsdiscover::doctor
