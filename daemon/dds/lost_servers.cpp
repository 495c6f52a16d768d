#include "dds/lost_servers.hpp"

#include <algorithm>

namespace rsd::dds {

void LostServers::participant_alive(const std::string& guid, Clock::time_point now) {
  alive_.insert(guid);
  if (auto it = lost_.find(guid); it != lost_.end() && !it->second.heard_at) it->second.heard_at = now;
}

void LostServers::participant_gone(const std::string& guid, Clock::time_point now) {
  alive_.erase(guid);
  gone_at_[guid] = now;
  if (auto it = lost_.find(guid); it != lost_.end()) {  // lost again, by this participant too
    it->second.lost_here = true;
    it->second.heard_at.reset();
  }
}

void LostServers::participant_rebuilt() {
  alive_.clear();
  suspects_.clear();
  gone_at_.clear();
  reading_since_.reset();
  for (auto& [guid, lost] : lost_) {  // the new participant hears it anew, without stale state
    lost.heard_at.reset();
    lost.lost_here = false;
  }
}

std::vector<std::string> LostServers::participants() const {
  std::vector<std::string> out;
  for (const auto& [guid, lost] : lost_) out.push_back(guid);
  return out;
}

void LostServers::writer_lost(const std::string& participant, Clock::time_point now) {
  if (!lost_.count(participant)) suspects_.emplace(participant, now);
}

std::optional<LostServers::Clock::time_point> LostServers::next_check(Clock::time_point now) const {
  std::optional<Clock::time_point> next;
  // Only what lies ahead: what is due now, check() has just done or declined.
  const auto consider = [&](Clock::time_point t) {
    if (t > now && (!next || t < *next)) next = t;
  };
  for (const auto& [guid, since] : suspects_) consider(since + times_.check_delay);
  for (const auto& [guid, lost] : lost_) {
    consider(lost.lost_at + times_.forget_after);
    consider(lost.next_refresh);
    if (!lost.lost_here || !lost.heard_at || !reading_since_) continue;
    consider(std::max(*lost.heard_at, *reading_since_) + times_.rematch_grace);
  }
  return next;
}

LostServers::Verdict LostServers::check(Clock::time_point now) {
  Verdict verdict;
  for (auto it = suspects_.begin(); it != suspects_.end();) {
    if (now - it->second < times_.check_delay) {
      ++it;
      continue;
    }
    // A participant still alive that never went only dropped a device (or a
    // writer): not lost. One that went and is back already is lost all the same.
    const auto gone = gone_at_.find(it->first);
    const bool went = gone != gone_at_.end() && gone->second + times_.check_delay >= it->second;
    const bool alive = alive_.count(it->first) > 0;
    if ((!alive || went) && !lost_.count(it->first)) {
      // A refresh made since the loss already served it (no second rebuild
      // 100 ms after the first): its count goes on from that one.
      const bool served = last_refresh_ && *last_refresh_ >= it->second;
      const std::optional<Clock::time_point> heard = alive ? std::optional(now) : std::nullopt;
      // Served: the participant that lost it is gone already.
      lost_[it->first] = served ? Lost{it->second, *last_refresh_ + times_.refresh_again, 1, heard, false}
                                : Lost{it->second, it->second + times_.refresh_first, 0, heard, true};
      verdict.newly_lost.push_back(it->first);
    }
    it = suspects_.erase(it);
  }
  std::erase_if(gone_at_, [&](const auto& kv) { return now - kv.second > 2 * times_.check_delay; });
  for (auto it = lost_.begin(); it != lost_.end();) {
    if (now - it->second.lost_at >= times_.forget_after) {
      verdict.given_up.push_back(it->first);
      it = lost_.erase(it);
      continue;
    }
    Lost& lost = it->second;
    const bool blind = now >= lost.next_refresh;
    // Heard again by the participant that lost it, with a reader to hear its
    // devices on, and still lost after the grace.
    const bool stale = lost.lost_here && lost.heard_at && reading_since_ &&
                       now - std::max(*lost.heard_at, *reading_since_) >= times_.rematch_grace;
    verdict.refresh = verdict.refresh || blind || stale;
    ++it;
  }
  if (!verdict.refresh) return verdict;
  last_refresh_ = now;
  // One refresh serves every lost server; each backs off on its own count.
  for (auto& [guid, lost] : lost_) {  // one refresh serves every lost server
    ++lost.refreshes;
    auto wait = times_.refresh_again;
    for (int i = 1; i < lost.refreshes && wait < times_.refresh_max; ++i) wait *= 4;
    lost.next_refresh = now + std::min(wait, times_.refresh_max);
  }
  return verdict;
}

}  // namespace rsd::dds
