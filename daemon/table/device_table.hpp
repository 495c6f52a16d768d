// The device table: every device the daemon knows, a generation counter and a
// bounded change log. Plain data, no locks and no threads: SharedTable wraps it
// for the sources' and frontends' threads, and the unit tests drive it directly.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace rsd {

enum class EventType { added, changed, removed };
const char* to_string(EventType type);

struct DeviceEvent {
  std::uint64_t generation = 0;  // strictly increasing, one per event; the SSE id
  EventType type = EventType::added;
  nlohmann::json device;  // the device as it is after the event (before it, for removed)
};

// What events_since() found in the change log.
struct EventsSince {
  std::vector<DeviceEvent> events;
  // The requested generation is older than the oldest event the log still holds
  // (or newer than anything issued): the caller must re-list instead.
  bool gap = false;
};

class DeviceTable {
 public:
  // Fields the table owns itself; a source's document never sets them.
  static constexpr const char* kFirstSeen = "first-seen";
  static constexpr const char* kLastSeen = "last-seen";

  // `first_generation` lets a restarted daemon continue above its predecessor's ids
  // (main seeds it from the clock), so a client resuming with an old id is told to
  // re-list instead of being handed unrelated events.
  explicit DeviceTable(std::size_t log_capacity = 4096, std::uint64_t first_generation = 0);

  // Adds the device `id` or updates it. `doc` is the whole device as its source
  // sees it now (an object; "id" is set here). Returns the event it caused, or
  // nothing when only last-seen moved: a periodic re-announcement is not news.
  std::optional<DeviceEvent> upsert(const std::string& id, nlohmann::json doc,
                                    const std::string& now_iso8601);

  // Removes the device; nothing happens (and no event) when it is not there.
  std::optional<DeviceEvent> remove(const std::string& id);

  // Removes every device whose document satisfies `pred`, one event each.
  std::vector<DeviceEvent> remove_if(const std::function<bool(const nlohmann::json&)>& pred);

  const nlohmann::json* find(const std::string& id) const;
  std::vector<nlohmann::json> devices() const;  // ordered by id
  std::size_t size() const { return devices_.size(); }

  std::uint64_t generation() const { return generation_; }
  EventsSince events_since(std::uint64_t generation) const;

 private:
  DeviceEvent record(EventType type, const nlohmann::json& device);

  std::map<std::string, nlohmann::json> devices_;
  std::deque<DeviceEvent> log_;
  std::size_t log_capacity_;
  std::uint64_t generation_ = 0;
};

}  // namespace rsd
