// Who announces itself on which DDS domain, heard without joining any: the RTPS
// participant announcements (SPDP) every DDS participant multicasts to
// 239.255.0.1 on its domain's discovery port, 7400 + 250 d (the RTPS port
// mapping). `rs-discover doctor` listens a few seconds on every domain's port to
// find a camera server on a domain the daemon does not join.
//
// SPDP names the participant (PID_ENTITY_NAME: realdds servers put the name they
// were given there), its vendor and its unicast addresses; which topics it writes
// (a realdds server's realsense/device-info) travel by unicast SEDP after it, so
// from here a camera server and a librealsense program look alike.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace rsdiscover::spdp {

inline constexpr int kMaxDomain = 232;  // the RTPS port mapping stops there
inline constexpr int discovery_port(int domain) { return 7400 + 250 * domain; }

struct Announcement {
  int domain = 0;
  std::string guid_prefix;  // "010f0d04.8a26b140.00000000", as the daemon prints GUIDs
  std::string vendor_id;    // "01.0f" (eProsima Fast DDS: realdds and librealsense)
  std::string name;         // "" when it gives none
  std::vector<std::string> addresses;  // its IPv4 unicast locators' hosts
};

// The announcement in one RTPS message received on domain `domain`'s discovery
// port, or nullopt when the message carries none (another submessage, a
// participant's goodbye, garbage). Never reads past `size`.
std::optional<Announcement> parse(const std::uint8_t* data, std::size_t size, int domain);

struct Heard {
  std::vector<Announcement> participants;  // one per domain and GUID prefix
  std::vector<int> listened;               // the domains whose port could be bound
};

// Listens on the discovery port of every domain 0..232 for `how_long`, joined to
// 239.255.0.1 on every IPv4 interface that is up and does multicast (ports are
// shared with the DDS participants of this host: SO_REUSEADDR, as they bind).
Heard listen(std::chrono::milliseconds how_long);

}  // namespace rsdiscover::spdp
