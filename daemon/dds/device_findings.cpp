// DomainBook's reads of its devices (their announcements in the camera's own
// words, their servers) and the daemon's own findings on them (who uses a device,
// whether it is ready), which the camera's announcements never overwrite.
#include "dds/domain_book.hpp"

#include "log/log.hpp"

#include <algorithm>

namespace rsd::dds {

namespace {

// A device's announcement in the camera's own words: what the daemon adds (its
// clients, whether it is ready or unresponsive) changes no description, so it must
// not look like a new announcement to the fetcher.
nlohmann::json own_words(model::Device doc) {
  doc.in_use.reset();
  doc.ready.reset();
  doc.ready_stage.reset();
  doc.unresponsive.reset();
  return model::to_json(doc);
}

}  // namespace

std::optional<nlohmann::json> DomainBook::announcement(const std::string& topic_root) const {
  const auto it = devices_.find(device_id(options_.domain, topic_root));
  if (it == devices_.end()) return std::nullopt;
  return own_words(it->second.doc);
}

std::map<std::string, nlohmann::json> DomainBook::announcements() const {
  std::map<std::string, nlohmann::json> out;
  for (const auto& [id, device] : devices_)
    if (device.doc.topic_root) out.emplace(*device.doc.topic_root, own_words(device.doc));
  return out;
}

std::optional<std::set<std::string>> DomainBook::servers_of(const std::string& topic_root) const {
  const auto it = devices_.find(device_id(options_.domain, topic_root));
  if (it == devices_.end()) return std::nullopt;
  std::set<std::string> out;
  for (const auto& [writer, server] : it->second.announcers) out.insert(participant_of(writer));
  return out;
}

bool DomainBook::has_device(std::string_view topic_root) const {
  return devices_.count(device_id(options_.domain, std::string(topic_root))) > 0;
}

std::set<std::string> DomainBook::servers_to_hear() const {
  std::set<std::string> out;
  for (const auto& [id, device] : devices_)
    for (const auto& [writer, server] : device.announcers) out.insert(participant_of(writer));
  for (auto& guid : lost_.participants()) out.insert(std::move(guid));
  return out;
}

bool DomainBook::set_in_use(const std::string& topic_root, const model::InUse& in_use, Clock::time_point now) {
  const std::string id = device_id(options_.domain, topic_root);
  const auto it = devices_.find(id);
  if (it == devices_.end()) return false;
  std::optional<model::InUse> next;
  if (in_use.clients > 0) next = in_use;
  // Takes something away from what the document says: a client, or a stream.
  const auto& was = it->second.doc.in_use;
  const bool loses = was && (!next || next->clients < was->clients ||
                             std::any_of(was->streaming.begin(), was->streaming.end(), [&](const std::string& s) {
                               return std::find(next->streaming.begin(), next->streaming.end(), s) == next->streaming.end();
                             }));
  if (loses && options_.in_use_hold.count() > 0) {
    auto [held, fresh] = in_use_held_.try_emplace(id, HeldInUse{next, now + options_.in_use_hold});
    if (!fresh) held->second.in_use = std::move(next);  // its time stays the first loss's
    return fresh;
  }
  in_use_held_.erase(id);
  write_in_use(id, std::move(next));
  return false;
}

std::optional<DomainBook::Clock::time_point> DomainBook::flush_in_use(Clock::time_point now) {
  std::optional<Clock::time_point> next;
  for (auto it = in_use_held_.begin(); it != in_use_held_.end();) {
    if (it->second.until > now) {
      if (!next || it->second.until < *next) next = it->second.until;
      ++it;
      continue;
    }
    write_in_use(it->first, std::move(it->second.in_use));
    it = in_use_held_.erase(it);
  }
  return next;
}

void DomainBook::write_in_use(const std::string& id, std::optional<model::InUse> in_use) {
  const auto it = devices_.find(id);
  if (it == devices_.end() || it->second.doc.in_use == in_use) return;
  it->second.doc.in_use = std::move(in_use);
  table_.upsert(id, it->second.doc, /*heard=*/false);  // a client came, not the camera
}

void DomainBook::set_readiness(const std::string& topic_root, bool ready, const std::string& stage) {
  const std::string id = device_id(options_.domain, topic_root);
  const auto it = devices_.find(id);
  if (it == devices_.end()) return;
  model::Device& doc = it->second.doc;
  const std::optional<std::string> now_stage = ready ? std::nullopt : std::optional<std::string>(stage);
  if (doc.ready == ready && doc.ready_stage == now_stage) return;
  if (!ready) log::warning(prefix() + "device " + id + " is not ready: its notification set got as far as " + stage);
  doc.ready = ready;
  doc.ready_stage = now_stage;
  table_.upsert(id, doc, /*heard=*/false);  // the daemon's finding, not the camera's word
}

std::set<std::string> DomainBook::topic_roots() const {
  std::set<std::string> out;
  for (const auto& [id, device] : devices_)
    if (device.doc.topic_root) out.insert(*device.doc.topic_root);
  return out;
}

}  // namespace rsd::dds
