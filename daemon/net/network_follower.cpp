#include "net/network_follower.hpp"

#include <algorithm>

namespace rsd::net {

bool operator==(const NetInterface& a, const NetInterface& b) {
  // What the domains are joined with: the name and the addresses (the flags only
  // decide whether an interface is chosen at all).
  return a.name == b.name && a.ipv4 == b.ipv4;
}

void NetworkFollower::changed(std::vector<NetInterface> chosen, Clock::time_point now) {
  ++changes_;
  pending_ = std::move(chosen);
  quiet_from_ = now + times_.settle;
}

std::optional<std::vector<NetInterface>> NetworkFollower::due(Clock::time_point now) {
  if (!pending_ || now < quiet_from_) return std::nullopt;
  if (*pending_ == joined_) {  // changed and changed back, or nothing the domains use
    pending_.reset();
    return std::nullopt;
  }
  if (last_refresh_) {
    if (now - *last_refresh_ >= times_.backoff_reset) backoff_ = std::chrono::milliseconds(0);
    if (now < *last_refresh_ + backoff_) return std::nullopt;  // wait() says how long
  }
  backoff_ = backoff_.count() == 0 ? times_.backoff_first : std::min(backoff_ * 2, times_.backoff_max);
  joined_ = std::move(*pending_);
  pending_.reset();
  last_refresh_ = now;
  ++refreshes_;
  return joined_;
}

std::optional<NetworkFollower::Clock::duration> NetworkFollower::wait(Clock::time_point now) const {
  if (!pending_) return std::nullopt;
  Clock::time_point at = quiet_from_;
  if (last_refresh_ && now - *last_refresh_ < times_.backoff_reset) at = std::max(at, *last_refresh_ + backoff_);
  return std::max(Clock::duration(0), at - now);
}

}  // namespace rsd::net
