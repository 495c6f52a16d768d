#include "table/device_table.hpp"

#include <algorithm>

namespace rsd {

const char* to_string(EventType type) {
  switch (type) {
    case EventType::added: return "added";
    case EventType::changed: return "changed";
    case EventType::removed: return "removed";
  }
  return "unknown";
}

DeviceTable::DeviceTable(std::size_t log_capacity, std::uint64_t first_generation)
    : log_capacity_(std::max<std::size_t>(1, log_capacity)), generation_(first_generation) {}

namespace {
// Two documents describe the same state when they differ only in the timestamps.
bool same_but_timestamps(const nlohmann::json& a, const nlohmann::json& b) {
  nlohmann::json x = a, y = b;
  for (auto* d : {&x, &y}) {
    d->erase(DeviceTable::kFirstSeen);
    d->erase(DeviceTable::kLastSeen);
  }
  return x == y;
}
}  // namespace

std::optional<DeviceEvent> DeviceTable::upsert(const std::string& id, nlohmann::json doc,
                                               const std::string& now) {
  if (!doc.is_object()) doc = nlohmann::json::object();
  doc["id"] = id;
  doc[kLastSeen] = now;
  auto it = devices_.find(id);
  if (it == devices_.end()) {
    doc[kFirstSeen] = now;
    auto& stored = devices_.emplace(id, std::move(doc)).first->second;
    return record(EventType::added, stored);
  }
  doc[kFirstSeen] = it->second.value(kFirstSeen, now);
  const bool changed = !same_but_timestamps(it->second, doc);
  it->second = std::move(doc);
  if (!changed) return std::nullopt;
  return record(EventType::changed, it->second);
}

std::optional<DeviceEvent> DeviceTable::remove(const std::string& id) {
  auto it = devices_.find(id);
  if (it == devices_.end()) return std::nullopt;
  nlohmann::json last = std::move(it->second);
  devices_.erase(it);
  return record(EventType::removed, last);
}

std::vector<DeviceEvent> DeviceTable::remove_if(
    const std::function<bool(const nlohmann::json&)>& pred) {
  std::vector<std::string> doomed;
  for (const auto& [id, doc] : devices_)
    if (pred(doc)) doomed.push_back(id);
  std::vector<DeviceEvent> events;
  for (const auto& id : doomed) events.push_back(*remove(id));
  return events;
}

const nlohmann::json* DeviceTable::find(const std::string& id) const {
  auto it = devices_.find(id);
  return it == devices_.end() ? nullptr : &it->second;
}

std::vector<nlohmann::json> DeviceTable::devices() const {
  std::vector<nlohmann::json> out;
  out.reserve(devices_.size());
  for (const auto& [id, doc] : devices_) out.push_back(doc);
  return out;
}

EventsSince DeviceTable::events_since(std::uint64_t generation) const {
  EventsSince out;
  if (generation > generation_) {  // a generation we never issued: another daemon's, or ours before a restart
    out.gap = true;
    return out;
  }
  if (generation == generation_) return out;
  // The log holds generations [front, generation_]; resuming needs generation+1 in it.
  if (log_.empty() || log_.front().generation > generation + 1) {
    out.gap = true;
    return out;
  }
  auto first = std::lower_bound(log_.begin(), log_.end(), generation + 1,
                                [](const DeviceEvent& e, std::uint64_t g) { return e.generation < g; });
  out.events.assign(first, log_.end());
  return out;
}

DeviceEvent DeviceTable::record(EventType type, const nlohmann::json& device) {
  DeviceEvent event{++generation_, type, device};
  log_.push_back(event);
  while (log_.size() > log_capacity_) log_.pop_front();
  return event;
}

}  // namespace rsd
