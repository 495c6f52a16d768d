// A domain's shared USB cameras: what goes into the table and what is refused.
#include "dds/share_book.hpp"

#include "log/log.hpp"

namespace rsd::dds {
namespace {

log::RateLimiter g_share_log;

}  // namespace

ShareBook::ShareBook(SharedTable& table, ShareBookOptions options) : table_(table), options_(std::move(options)) {}

void ShareBook::sample(Instance instance, const std::string& participant_guid,
                       std::variant<SharedCamera, Rejected> parsed) {
  if (!own_.empty() && participant_guid == own_) return;  // our own cameras, already listed as "usb"
  if (auto* r = std::get_if<Rejected>(&parsed)) {
    // A known camera keeps its last good document: one bad sample is counted, not a departure.
    reject(r->reason, r->detail, participant_guid);
    return;
  }
  auto& cam = std::get<SharedCamera>(parsed);
  auto it = instances_.find(instance);
  if (it == instances_.end()) {
    // A camera heard again after a new reader is no new camera: not counted twice.
    auto stale = stale_.find(cam.id);
    const bool known = stale != stale_.end();
    if (!known && per_participant_[participant_guid] >= options_.max_per_participant) {
      if (per_participant_[participant_guid] == 0) per_participant_.erase(participant_guid);
      reject("shared-participant-limit", cam.id, participant_guid);
      return;
    }
    if (!known && instances_.size() + stale_.size() >= options_.max_per_domain) {
      if (per_participant_[participant_guid] == 0) per_participant_.erase(participant_guid);
      reject("shared-domain-limit", cam.id, participant_guid);
      return;
    }
    if (known) {
      if (auto p = per_participant_.find(stale->second.participant); p != per_participant_.end() && --p->second == 0)
        per_participant_.erase(p);
      stale_.erase(stale);
    }
    if (auto other = by_id_.find(cam.id); other != by_id_.end()) {
      // The key decides the id, so only a reader made anew meanwhile gets here.
      drop(instances_.find(other->second), "replaced");
    }
    it = instances_.emplace(instance, Entry{cam.id, participant_guid, nlohmann::json()}).first;
    by_id_[cam.id] = instance;
    ++per_participant_[participant_guid];
    log::info(log::domain_prefix(options_.domain) + "shared camera " + cam.id + " from " + participant_guid);
  } else if (it->second.participant != participant_guid) {
    // Another writer of the same key (the sharer restarted before its old lease ran out).
    if (auto p = per_participant_.find(it->second.participant); p != per_participant_.end() && --p->second == 0)
      per_participant_.erase(p);
    ++per_participant_[participant_guid];
    it->second.participant = participant_guid;
  }
  if (it->second.doc != cam.device) {
    it->second.doc = cam.device;
    table_.upsert(cam.id, std::move(cam.device));
  }
}

void ShareBook::instance_gone(Instance instance) {
  auto it = instances_.find(instance);
  if (it != instances_.end()) drop(it, "gone");
}

void ShareBook::drop(std::map<Instance, Entry>::iterator it, const char* why) {
  if (it == instances_.end()) return;
  log::info(log::domain_prefix(options_.domain) + "shared camera " + it->second.id + " " + why);
  table_.remove(it->second.id);
  by_id_.erase(it->second.id);
  if (auto p = per_participant_.find(it->second.participant); p != per_participant_.end() && --p->second == 0)
    per_participant_.erase(p);
  instances_.erase(it);
}

void ShareBook::reader_made(Clock::time_point now) {
  for (auto& [instance, e] : instances_) stale_.emplace(e.id, std::move(e));
  instances_.clear();
  by_id_.clear();
  if (!stale_.empty()) reconcile_at_ = now + options_.reconcile_grace;
}

ShareBook::Clock::duration ShareBook::tick(Clock::time_point now) {
  if (!reconcile_at_) return std::chrono::seconds(1);
  if (now < *reconcile_at_) return *reconcile_at_ - now;
  for (auto& [id, e] : stale_) {
    log::info(log::domain_prefix(options_.domain) + "shared camera " + id + " not heard again");
    table_.remove(id);
    if (auto p = per_participant_.find(e.participant); p != per_participant_.end() && --p->second == 0)
      per_participant_.erase(p);
  }
  stale_.clear();
  reconcile_at_.reset();
  return std::chrono::seconds(1);
}

void ShareBook::forget_devices() {
  for (const auto& [instance, e] : instances_) table_.remove(e.id);
  for (const auto& [id, e] : stale_) table_.remove(id);
  instances_.clear();
  by_id_.clear();
  stale_.clear();
  per_participant_.clear();
  reconcile_at_.reset();
}

void ShareBook::fill(DomainStatus& status) const {
  for (const auto& [reason, n] : rejected_) status.rejected[reason] += n;
}

void ShareBook::reject(const std::string& reason, const std::string& detail, const std::string& sender) {
  ++rejected_[reason];
  std::uint64_t suppressed = 0;
  if (g_share_log.allow(std::to_string(options_.domain) + "/" + sender + "/" + reason, suppressed))
    log::warning(log::domain_prefix(options_.domain) + "refused a shared camera from " + sender + ": " + reason +
                 " (" + detail + ")" +
                 (suppressed ? "; " + std::to_string(suppressed) + " more like it suppressed" : ""));
}

}  // namespace rsd::dds
