// Whether a host is still on the network, judged from what a probe saw: the error
// its UDP socket got (the host's or a router's ICMP answer, or the kernel's own
// when address resolution failed) and the kernel's neighbour entry for it. Pure, so
// unit tests give it made-up observations; HostProbe (host_probe.hpp) gathers them.
#pragma once

#include "rsd_model/removal.hpp"

#include <chrono>
#include <optional>

namespace rsd::net {

struct NeighbourSeen {
  std::uint16_t state = 0;  // NUD_* (linux/neighbour.h)
  // How long ago the kernel last confirmed the neighbour (an ARP answer).
  std::chrono::milliseconds confirmed_ago{0};
};

struct ProbeSeen {
  std::chrono::milliseconds elapsed{0};  // since the first datagram
  int socket_error = 0;                  // errno the socket reported, 0: none
  std::optional<NeighbourSeen> neighbour;  // none: no entry (not on a local link, or never resolved)
};

// present: the host's kernel answered (port unreachable, or an ARP answer after the
// probe began). unreachable: resolving it failed, or a router says so. Nothing yet:
// probe on.
std::optional<model::HostVerdict> judge_host(const ProbeSeen& seen);

}  // namespace rsd::net
