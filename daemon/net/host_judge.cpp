// What a host probe's observations mean (host_judge.hpp).
#include "net/host_judge.hpp"

#include <linux/neighbour.h>

#include <cerrno>

namespace rsd::net {

std::optional<model::HostVerdict> judge_host(const ProbeSeen& seen) {
  // A hung server's kernel still runs: it refuses a datagram to a closed port.
  if (seen.socket_error == ECONNREFUSED) return model::HostVerdict::present;
  if (seen.socket_error == EHOSTUNREACH || seen.socket_error == ENETUNREACH || seen.socket_error == EHOSTDOWN)
    return model::HostVerdict::unreachable;
  if (!seen.neighbour) return std::nullopt;
  const NeighbourSeen& n = *seen.neighbour;
  // Confirmed since the probe began: it answered ARP just now. A REACHABLE entry
  // confirmed before is only the kernel's memory of it (up to ~45 s old).
  if ((n.state & (NUD_REACHABLE | NUD_STALE | NUD_DELAY | NUD_PROBE)) && n.confirmed_ago < seen.elapsed)
    return model::HostVerdict::present;
  if (n.state & NUD_FAILED) return model::HostVerdict::unreachable;
  return std::nullopt;
}

}  // namespace rsd::net
