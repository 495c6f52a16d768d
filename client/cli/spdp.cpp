#include "spdp.hpp"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <set>
#include <utility>

namespace rsdiscover::spdp {
namespace {

// RTPS 2.x (OMG DDSI-RTPS, 9.4 and 9.6): the pieces an SPDP announcement needs.
constexpr std::size_t kHeader = 20;  // "RTPS", version, vendor id, GUID prefix
constexpr std::uint8_t kData = 0x15;
constexpr std::uint8_t kFlagLittleEndian = 0x01, kFlagInlineQos = 0x02, kFlagData = 0x04;
constexpr std::uint8_t kSpdpWriter[4] = {0x00, 0x01, 0x00, 0xc2};  // ENTITYID_SPDP_BUILTIN_PARTICIPANT_WRITER
constexpr std::uint16_t kPidSentinel = 0x0001, kPidDefaultUnicast = 0x0031, kPidMetatrafficUnicast = 0x0032,
                        kPidEntityName = 0x0062;
constexpr std::int32_t kLocatorUdpV4 = 1;

std::uint16_t u16(const std::uint8_t* p, bool little) {
  return little ? static_cast<std::uint16_t>(p[0] | p[1] << 8) : static_cast<std::uint16_t>(p[0] << 8 | p[1]);
}
std::uint32_t u32(const std::uint8_t* p, bool little) {
  return little ? std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24
                : std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 | std::uint32_t(p[3]);
}

std::string hex(const std::uint8_t* p, std::size_t n) {
  std::string out;
  char b[3];
  for (std::size_t i = 0; i < n; ++i) {
    std::snprintf(b, sizeof b, "%02x", p[i]);
    out += b;
  }
  return out;
}

// A parameter list (9.4.2.11) from `p` to `end`; `on` gets each parameter. Where
// the list ends (after its sentinel), or nullptr when it is cut short.
template <typename On>
const std::uint8_t* parameters(const std::uint8_t* p, const std::uint8_t* end, bool little, On on) {
  while (end - p >= 4) {
    const auto pid = u16(p, little), length = u16(p + 2, little);
    p += 4;
    if (pid == kPidSentinel) return p;
    if (length > end - p) return nullptr;
    on(pid, p, length);
    p += length;
  }
  return nullptr;
}

// A printable name: an entity name is the peer's to choose, and goes to a terminal.
std::string printable(const std::uint8_t* p, std::size_t n) {
  std::string out;
  for (std::size_t i = 0; i < n && p[i]; ++i) out += (p[i] >= 0x20 && p[i] < 0x7f) ? static_cast<char>(p[i]) : '?';
  return out;
}

}  // namespace

std::optional<Announcement> parse(const std::uint8_t* data, std::size_t size, int domain) {
  if (size < kHeader || std::memcmp(data, "RTPS", 4) != 0) return std::nullopt;
  Announcement a;
  a.domain = domain;
  char vendor[8];
  std::snprintf(vendor, sizeof vendor, "%02x.%02x", data[6], data[7]);
  a.vendor_id = vendor;
  a.guid_prefix = hex(data + 8, 4) + "." + hex(data + 12, 4) + "." + hex(data + 16, 4);
  const std::uint8_t* p = data + kHeader;
  const std::uint8_t* const end = data + size;
  while (end - p >= 4) {
    const std::uint8_t id = p[0], flags = p[1];
    const bool little = flags & kFlagLittleEndian;
    std::size_t length = u16(p + 2, little);
    p += 4;
    if (length == 0 && id != 0x01 && id != 0x09) length = static_cast<std::size_t>(end - p);  // to the end (8.3.3.2)
    if (length > static_cast<std::size_t>(end - p)) return std::nullopt;
    const std::uint8_t* const body = p;
    p += length;
    if (id != kData || !(flags & kFlagData) || length < 20) continue;
    if (std::memcmp(body + 8, kSpdpWriter, 4) != 0) continue;
    const std::uint8_t* q = body + 4 + u16(body + 2, little);  // octetsToInlineQos counts from after itself
    if (q > body + length) return std::nullopt;
    if (flags & kFlagInlineQos) {
      q = parameters(q, body + length, little, [](std::uint16_t, const std::uint8_t*, std::uint16_t) {});
      if (!q) return std::nullopt;
    }
    if (body + length - q < 4) return std::nullopt;
    // The payload's encapsulation: PL_CDR_BE (0x0002) or PL_CDR_LE (0x0003).
    if (q[0] != 0 || (q[1] != 0x02 && q[1] != 0x03)) return std::nullopt;
    const bool payload_little = q[1] == 0x03;
    std::set<std::string> addresses;
    const bool ok = parameters(q + 4, body + length, payload_little,
                               [&](std::uint16_t pid, const std::uint8_t* v, std::uint16_t n) {
      if (pid == kPidEntityName && n >= 4) {
        const auto chars = u32(v, payload_little);
        a.name = printable(v + 4, std::min<std::size_t>(chars, n - 4u));
      } else if ((pid == kPidDefaultUnicast || pid == kPidMetatrafficUnicast) && n >= 24 &&
                 static_cast<std::int32_t>(u32(v, payload_little)) == kLocatorUdpV4) {
        char text[INET_ADDRSTRLEN];
        if (inet_ntop(AF_INET, v + 20, text, sizeof text)) addresses.insert(text);
      }
    }) != nullptr;
    if (!ok) return std::nullopt;
    a.addresses.assign(addresses.begin(), addresses.end());
    return a;
  }
  return std::nullopt;
}

Heard listen(std::chrono::milliseconds how_long) {
  // The interfaces to join the discovery group on.
  std::vector<unsigned> interfaces;
  if (ifaddrs* list = nullptr; getifaddrs(&list) == 0) {
    for (ifaddrs* i = list; i; i = i->ifa_next)
      if (i->ifa_addr && i->ifa_addr->sa_family == AF_INET && (i->ifa_flags & IFF_UP) &&
          (i->ifa_flags & IFF_MULTICAST))
        if (const unsigned index = if_nametoindex(i->ifa_name); index &&
            std::find(interfaces.begin(), interfaces.end(), index) == interfaces.end())
          interfaces.push_back(index);
    freeifaddrs(list);
  }
  if (interfaces.size() > 20) interfaces.resize(20);  // net.ipv4.igmp_max_memberships, per socket

  Heard heard;
  std::vector<pollfd> fds;
  std::vector<int> domain_of;
  for (int d = 0; d <= kMaxDomain; ++d) {
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd < 0) break;  // out of descriptors: listen on those there are
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in at{};
    at.sin_family = AF_INET;
    at.sin_port = htons(static_cast<std::uint16_t>(discovery_port(d)));
    at.sin_addr.s_addr = htonl(INADDR_ANY);
    if (::bind(fd, reinterpret_cast<sockaddr*>(&at), sizeof at) != 0) {
      ::close(fd);  // taken by a socket that shares it with nobody
      continue;
    }
    for (unsigned index : interfaces) {
      ip_mreqn join{};
      join.imr_multiaddr.s_addr = htonl(0xEFFF0001);  // 239.255.0.1
      join.imr_ifindex = static_cast<int>(index);
      ::setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &join, sizeof join);
    }
    fds.push_back({fd, POLLIN, 0});
    domain_of.push_back(d);
    heard.listened.push_back(d);
  }

  std::set<std::pair<int, std::string>> seen;
  const auto until = std::chrono::steady_clock::now() + how_long;
  std::vector<std::uint8_t> buffer(65536);
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now());
    if (left.count() <= 0 || fds.empty()) break;
    if (::poll(fds.data(), fds.size(), static_cast<int>(left.count())) <= 0) continue;
    for (std::size_t i = 0; i < fds.size(); ++i) {
      if (!(fds[i].revents & POLLIN)) continue;
      for (;;) {
        const ssize_t n = ::recv(fds[i].fd, buffer.data(), buffer.size(), 0);
        if (n <= 0) break;
        auto a = parse(buffer.data(), static_cast<std::size_t>(n), domain_of[i]);
        if (!a) continue;
        if (const auto key = std::make_pair(a->domain, a->guid_prefix); !seen.count(key)) {
          seen.insert(key);
          heard.participants.push_back(std::move(*a));
        } else if (!a->name.empty()) {
          // An announcement may change (a name set late): keep the latest.
          for (auto& p : heard.participants)
            if (p.domain == a->domain && p.guid_prefix == a->guid_prefix) p = std::move(*a);
        }
      }
    }
  }
  for (const auto& f : fds) ::close(f.fd);
  return heard;
}

}  // namespace rsdiscover::spdp
