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
      release(per_participant_.find(stale->second.entry.participant));
      it = instances_.emplace(instance, std::move(stale->second.entry)).first;
      stale_.erase(stale);
      it->second.participant = participant_guid;
      by_id_[cam.id] = instance;
      ++per_participant_[participant_guid];
    }
    if (!known) {
      if (auto other = by_id_.find(cam.id); other != by_id_.end()) {
        // The key decides the id: only an instance handle Cyclone gave anew gets here.
        drop(instances_.find(other->second), "replaced", model::RemovalReason::writer_gone);
      }
      it = instances_.emplace(instance, Entry{cam.id, participant_guid, nlohmann::json()}).first;
      by_id_[cam.id] = instance;
      ++per_participant_[participant_guid];
      log::info(log::domain_prefix(options_.domain) + "shared camera " + cam.id + " from " + participant_guid);
    }
  } else if (it->second.participant != participant_guid) {
    // Another writer of the same key (the sharer restarted before its old lease ran out).
    release(per_participant_.find(it->second.participant));
    ++per_participant_[participant_guid];
    it->second.participant = participant_guid;
  }
  if (it->second.doc != cam.device) {
    it->second.doc = cam.device;
    table_.hold(options_.domain, cam.id, std::move(cam.device));
  }
}

void ShareBook::instance_gone(Instance instance, bool disposed, Clock::time_point now) {
  auto it = instances_.find(instance);
  if (it == instances_.end()) return;
  if (disposed) {
    drop(it, "unshared", model::RemovalReason::unplugged);  // its host says it left
    return;
  }
  log::debug([&] { return log::domain_prefix(options_.domain) + "shared camera " + it->second.id + " lost its writer"; });
  by_id_.erase(it->second.id);
  std::string id = it->second.id;
  stale_.insert_or_assign(std::move(id), Stale{std::move(it->second), now + options_.orphan_grace});
  instances_.erase(it);
}

void ShareBook::release(std::map<std::string, std::size_t>::iterator p) {
  if (p != per_participant_.end() && --p->second == 0) per_participant_.erase(p);
}

void ShareBook::drop(std::map<Instance, Entry>::iterator it, const char* why, model::RemovalReason reason) {
  if (it == instances_.end()) return;
  log::info(log::domain_prefix(options_.domain) + "shared camera " + it->second.id + " " + why);
  table_.release(options_.domain, it->second.id, reason);
  by_id_.erase(it->second.id);
  release(per_participant_.find(it->second.participant));
  instances_.erase(it);
}

void ShareBook::reader_made(Clock::time_point now) {
  for (auto& [instance, e] : instances_) {
    std::string id = e.id;
    stale_.insert_or_assign(std::move(id), Stale{std::move(e), now + options_.reconcile_grace});
  }
  instances_.clear();
  by_id_.clear();
}

ShareBook::Clock::duration ShareBook::tick(Clock::time_point now) {
  Clock::duration next = kIdle;
  for (auto it = stale_.begin(); it != stale_.end();) {
    if (now < it->second.until) {
      next = std::min<Clock::duration>(next, it->second.until - now);
      ++it;
      continue;
    }
    log::info(log::domain_prefix(options_.domain) + "shared camera " + it->first + " not heard again");
    table_.release(options_.domain, it->first, model::RemovalReason::lease_expired);
    release(per_participant_.find(it->second.entry.participant));
    it = stale_.erase(it);
  }
  return next;
}

void ShareBook::forget_devices(model::RemovalReason reason) {
  for (const auto& [instance, e] : instances_) table_.release(options_.domain, e.id, reason);
  for (const auto& [id, e] : stale_) table_.release(options_.domain, id, reason);
  instances_.clear();
  by_id_.clear();
  stale_.clear();
  per_participant_.clear();
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
