#include "table/shared_table.hpp"

#include <ctime>

namespace rsd {

void SharedTable::announce() {
  changed_.notify_all();
  std::lock_guard lock(hook_mutex_);
  for (const auto& [id, hook] : hooks_) hook();
}

SharedTable::HookId SharedTable::add_change_hook(std::function<void()> hook) {
  std::lock_guard lock(hook_mutex_);
  hooks_.emplace(next_hook_, std::move(hook));
  return next_hook_++;
}

void SharedTable::remove_change_hook(HookId id) {
  std::lock_guard lock(hook_mutex_);
  hooks_.erase(id);
}

std::optional<DeviceEvent> SharedTable::upsert(const std::string& id, const nlohmann::json& doc, bool heard) {
  return upsert(id, doc.is_object() ? model::device_from_json(doc) : model::Device{}, heard);
}

std::optional<DeviceEvent> SharedTable::upsert(const std::string& id, model::Device doc, bool heard) {
  std::optional<DeviceEvent> event;
  {
    std::lock_guard lock(mutex_);
    event = table_.upsert(id, std::move(doc), now_iso8601(), heard);
    generation_ = table_.generation();
  }
  if (event) announce();
  return event;
}

std::optional<DeviceEvent> SharedTable::remove(const std::string& id, model::RemovalReason reason,
                                               std::string detail) {
  std::optional<DeviceEvent> event;
  const std::string now = now_iso8601(), cutoff = gone_cutoff();
  {
    std::lock_guard lock(mutex_);
    table_.expire_gone(cutoff);
    event = table_.remove(id, reason, now, std::move(detail));
    generation_ = table_.generation();
  }
  if (event) announce();
  return event;
}

bool SharedTable::judge_host(const std::string& entry_id, std::uint64_t removal, model::HostVerdict verdict) {
  std::lock_guard lock(mutex_);
  return table_.judge_host(entry_id, removal, verdict);
}

std::optional<DeviceEvent> SharedTable::hold(int owner, const std::string& id, nlohmann::json doc) {
  std::optional<DeviceEvent> event;
  {
    std::lock_guard lock(mutex_);
    auto& owners = held_[id];
    owners[owner] = doc;
    if (owners.begin()->first != owner) return std::nullopt;  // a lower owner's document shows
    event = table_.upsert(id, std::move(doc), now_iso8601());
    generation_ = table_.generation();
  }
  if (event) announce();
  return event;
}

std::optional<DeviceEvent> SharedTable::release(int owner, const std::string& id, model::RemovalReason reason) {
  std::optional<DeviceEvent> event;
  {
    std::lock_guard lock(mutex_);
    const auto it = held_.find(id);
    if (it == held_.end() || !it->second.contains(owner)) return std::nullopt;
    const bool showing = it->second.begin()->first == owner;
    it->second.erase(owner);
    if (it->second.empty()) {
      held_.erase(it);
      event = table_.remove(id, reason, now_iso8601());
    } else if (showing) {
      event = table_.upsert(id, it->second.begin()->second, now_iso8601());
    }
    generation_ = table_.generation();
  }
  if (event) announce();
  return event;
}

std::optional<DeviceEvent> SharedTable::note_described(const std::string& id) {
  std::optional<DeviceEvent> event;
  {
    std::lock_guard lock(mutex_);
    event = table_.note_described(id);
    generation_ = table_.generation();
  }
  if (event) announce();
  return event;
}

std::vector<DeviceEvent> SharedTable::remove_if(const std::function<bool(const model::Device&)>& pred,
                                               model::RemovalReason reason) {
  std::vector<DeviceEvent> events;
  const std::string now = now_iso8601();
  {
    std::lock_guard lock(mutex_);
    events = table_.remove_if(pred, reason, now);
    generation_ = table_.generation();
  }
  if (!events.empty()) announce();
  return events;
}

TableSnapshot SharedTable::snapshot() const {
  std::lock_guard lock(mutex_);
  return {table_.generation(), table_.entries()};
}

EntryPtr SharedTable::find_entry(const std::string& id) const {
  std::lock_guard lock(mutex_);
  return table_.find(id);
}

std::optional<nlohmann::json> SharedTable::find(const std::string& id) const {
  if (const auto entry = find_entry(id)) return model::to_json(entry->device);
  return std::nullopt;
}

std::uint64_t SharedTable::generation() const { return generation_.load(); }

std::string SharedTable::gone_cutoff() const {
  return iso8601(std::chrono::system_clock::now() - table_.limits().gone_keep);
}

std::optional<GoneEntry> SharedTable::find_gone(const std::string& key) const {
  const std::string cutoff = gone_cutoff();
  std::lock_guard lock(mutex_);
  auto gone = table_.find_gone(key);
  if (gone && gone->removed_at < cutoff) return std::nullopt;
  return gone;
}

std::optional<CameraHistory> SharedTable::history(const std::string& key) const {
  std::lock_guard lock(mutex_);
  return table_.history(key);
}

TableCounts SharedTable::counts() const {
  std::lock_guard lock(mutex_);
  return table_.counts();
}

std::vector<HistoryRecord> SharedTable::history_since(std::uint64_t generation, std::size_t max) const {
  std::lock_guard lock(mutex_);
  return table_.history_since(generation, max);
}

EventsSince SharedTable::wait_events(std::uint64_t generation,
                                     std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  changed_.wait_for(lock, timeout, [&] { return closed_ || table_.generation() != generation; });
  return table_.events_since(generation);
}

void SharedTable::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  changed_.notify_all();
}

bool SharedTable::closed() const {
  std::lock_guard lock(mutex_);
  return closed_;
}

std::string SharedTable::now_iso8601() { return iso8601(std::chrono::system_clock::now()); }

std::string SharedTable::iso8601(std::chrono::system_clock::time_point now) {
  using namespace std::chrono;
  const auto ms = duration_cast<milliseconds>(now.time_since_epoch()).count() % 1000;
  const std::time_t t = system_clock::to_time_t(now);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  char out[48];
  std::snprintf(out, sizeof out, "%s.%03dZ", buf, static_cast<int>(ms));
  return out;
}

}  // namespace rsd
