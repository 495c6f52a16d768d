// DomainBook's removal grace (BookOptions::removal_grace): a device whose server's
// lease ran out stays listed, marked unresponsive, until its grace ends, and goes
// with `lease-expired` then unless it was announced again meanwhile, or its server
// was heard again (then heard_again_grace longer, for its device to follow, as
// long as the server is heard again each time, a few times at most).
#include "dds/domain_book.hpp"

#include "log/log.hpp"

#include <algorithm>

namespace rsd::dds {

void DomainBook::mark_unresponsive(const std::string& id, Clock::time_point now) {
  if (!unresponsive_.emplace(id, Grace{now + options_.removal_grace}).second) return;
  Announced& device = devices_.at(id);
  device.doc.unresponsive = true;
  log::info(prefix() + "device " + id + " unresponsive (its server's lease expired): removed in " +
            std::to_string(std::chrono::duration_cast<std::chrono::seconds>(options_.removal_grace).count()) +
            " s unless heard again");
  table_.upsert(id, device.doc, /*heard=*/false);  // last-seen: when it was last heard
}

void DomainBook::participant_alive(const std::string& guid, Clock::time_point now) {
  lost_.participant_alive(guid, now);
  for (auto& [id, grace] : unresponsive_) {
    if (grace.heard) continue;
    const auto dev = devices_.find(id);
    if (dev == devices_.end()) continue;
    const auto& list = dev->second.announcers;
    grace.heard = std::any_of(list.begin(), list.end(), [&](const auto& a) { return participant_of(a.first) == guid; });
  }
}

void DomainBook::end_graces(Clock::time_point now) {
  for (auto it = unresponsive_.begin(); it != unresponsive_.end();) {
    if (now < it->second.until) {
      ++it;
      continue;
    }
    const std::string id = it->first;
    const auto dev = devices_.find(id);
    if (dev == devices_.end()) {
      it = unresponsive_.erase(it);
      continue;
    }
    if (it->second.heard && it->second.extensions < kMaxGraceExtensions) {
      it->second.until = now + options_.heard_again_grace;
      it->second.heard = false;
      ++it->second.extensions;
      log::info(prefix() + "device " + id + ": its server was heard again, its device-info not yet: kept " +
                std::to_string(std::chrono::duration_cast<std::chrono::seconds>(options_.heard_again_grace).count()) +
                " s more");
      ++it;
      continue;
    }
    it = unresponsive_.erase(it);
    std::vector<std::string> writers;
    for (const auto& a : dev->second.announcers) writers.push_back(a.first);
    if (writers.empty()) remove_device(id, model::RemovalReason::lease_expired, "not heard again within the removal grace");
    for (const auto& w : writers)
      drop_announcer(id, w, model::RemovalReason::lease_expired,
                     "its participant " + participant_of(w) + " is gone (its lease expired) and was not heard again within the removal grace");
  }
}

}  // namespace rsd::dds
