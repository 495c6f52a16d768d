// Asks the network whether a host is still there, with no privilege: a UDP datagram
// to the discard port of each of its addresses, sent again each second (which also
// makes the kernel resolve, or re-check, the neighbour), the ICMP answer read from
// the connected socket, and the kernel's neighbour entry read by rtnetlink
// (RTM_GETNEIGH). host_judge.hpp says what they mean.
#pragma once

#include "net/host_judge.hpp"

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace rsd::net {

class HostProbe {
 public:
  using Clock = std::chrono::steady_clock;

  // IPv4 addresses in dotted form; others are skipped. `give_up_after`: no verdict
  // by then means none (a host off-link that drops probes tells nothing either way).
  HostProbe(const std::vector<std::string>& addresses, Clock::time_point now,
            std::chrono::milliseconds give_up_after = std::chrono::seconds(60));
  ~HostProbe();
  HostProbe(HostProbe&& other) noexcept;
  HostProbe& operator=(HostProbe&& other) noexcept;
  HostProbe(const HostProbe&) = delete;
  HostProbe& operator=(const HostProbe&) = delete;

  // present as soon as one address is; unreachable once every address is.
  std::optional<model::HostVerdict> poll(Clock::time_point now);
  bool given_up(Clock::time_point now) const { return targets_.empty() || now >= started_ + give_up_after_; }
  Clock::time_point next_send() const { return next_send_; }

 private:
  struct Target {
    std::uint32_t address = 0;  // network order
    int fd = -1;
    std::optional<model::HostVerdict> verdict;
  };
  std::vector<Target> targets_;
  Clock::time_point started_, next_send_;
  std::chrono::milliseconds give_up_after_;
};

// The kernel's neighbour entry for an IPv4 address (network order), if it has one.
std::optional<NeighbourSeen> neighbour_of(std::uint32_t address);

}  // namespace rsd::net
