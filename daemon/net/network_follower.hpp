// When the DDS domains should be joined anew on the host's network: the kernel
// says something changed (rtnetlink), the daemon lists the interfaces it would
// choose now, and this decides. Pure bookkeeping with made-up times in its unit
// tests, as LostServers is.
//
// - A burst of changes (a DHCP lease, a roam: link, address, route messages in
//   a few hundred ms) costs one refresh: the choice is judged `settle` after the
//   last change.
// - A change that leaves the choice as it was (a DHCP renewal, an IPv6 address,
//   an interface the rules exclude) costs nothing.
// - A host whose addresses flap (a bad DHCP server) gets refreshes spaced by a
//   back-off that doubles with each refresh close to the last, up to
//   `backoff_max`, and comes back down after a quiet `backoff_reset`.
#pragma once

#include "net/interfaces.hpp"

#include <chrono>
#include <cstdint>
#include <optional>
#include <vector>

namespace rsd::net {

struct FollowerTimes {
  std::chrono::milliseconds settle{300};
  std::chrono::milliseconds backoff_first{1000};
  std::chrono::milliseconds backoff_max{std::chrono::seconds(30)};
  std::chrono::milliseconds backoff_reset{std::chrono::seconds(60)};
};

class NetworkFollower {
 public:
  using Clock = std::chrono::steady_clock;

  // `joined`: the choice the domains were joined with at start.
  NetworkFollower(std::vector<NetInterface> joined, FollowerTimes times = {})
      : joined_(std::move(joined)), times_(times) {}

  // The kernel reported a change at `now`; `chosen` is the choice as it is now.
  void changed(std::vector<NetInterface> chosen, Clock::time_point now);

  // The choice to join the domains on now, if a refresh is due; it counts as
  // joined from here on.
  std::optional<std::vector<NetInterface>> due(Clock::time_point now);

  // How long until due() may have something (nullopt: nothing pending).
  std::optional<Clock::duration> wait(Clock::time_point now) const;

  const std::vector<NetInterface>& joined() const { return joined_; }
  std::uint64_t refreshes() const { return refreshes_; }  // changes followed
  std::uint64_t changes() const { return changes_; }      // kernel reports seen
  std::optional<Clock::time_point> last_refresh() const { return last_refresh_; }

 private:
  std::vector<NetInterface> joined_;
  FollowerTimes times_;
  std::optional<std::vector<NetInterface>> pending_;  // the latest choice, not yet judged
  Clock::time_point quiet_from_{};                    // the last change + settle
  std::optional<Clock::time_point> last_refresh_;
  std::chrono::milliseconds backoff_{0};  // the least time between two refreshes now
  std::uint64_t refreshes_ = 0, changes_ = 0;
};

bool operator==(const NetInterface& a, const NetInterface& b);

}  // namespace rsd::net
