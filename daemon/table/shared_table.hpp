// The one locked door to the device table. Sources (DDS listener threads, the
// libusb event thread) write through it; frontends read snapshots and wait for
// events through it. Nothing else holds the table.
#pragma once

#include "table/device_table.hpp"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>

namespace rsd {

struct TableSnapshot {
  std::uint64_t generation = 0;
  std::vector<EntryPtr> devices;  // ordered by id; shared, not copied
};

class SharedTable {
 public:
  explicit SharedTable(std::size_t log_capacity = 4096, std::uint64_t first_generation = 0,
                       HistoryLimits limits = {})
      : table_(log_capacity, first_generation, 128 * 1024, limits), generation_(first_generation) {}

  std::optional<DeviceEvent> upsert(const std::string& id, model::Device doc, bool heard = true);
  std::optional<DeviceEvent> upsert(const std::string& id, const nlohmann::json& doc, bool heard = true);
  // DeviceTable::remove, now; gone entries older than HistoryLimits::gone_keep go too.
  std::optional<DeviceEvent> remove(const std::string& id, model::RemovalReason reason, std::string detail = {});
  std::optional<DeviceEvent> note_described(const std::string& id);
  // A sighting that several owners report at once: another host's USB camera, shared
  // on each DDS domain that host and this daemon are both on (the owners are the
  // domains). It stays while any owner holds it and shows the document of the lowest
  // owner holding it, so one domain letting go (its sharer's lease there ran out)
  // does not remove a camera another domain still shows.
  std::optional<DeviceEvent> hold(int owner, const std::string& id, nlohmann::json doc);
  // `reason`: why, if this was the last owner holding it.
  std::optional<DeviceEvent> release(int owner, const std::string& id, model::RemovalReason reason);
  // DeviceTable::judge_host.
  bool judge_host(const std::string& entry_id, std::uint64_t removal, model::HostVerdict verdict);
  std::vector<DeviceEvent> remove_if(const std::function<bool(const model::Device&)>& pred,
                                     model::RemovalReason reason);

  TableSnapshot snapshot() const;
  EntryPtr find_entry(const std::string& id) const;  // DeviceTable::find
  std::optional<nlohmann::json> find(const std::string& id) const;  // the same, as JSON
  std::uint64_t generation() const;
  // DeviceTable's, with gone entries past HistoryLimits::gone_keep left out.
  std::optional<GoneEntry> find_gone(const std::string& key) const;
  std::optional<CameraHistory> history(const std::string& key) const;
  std::vector<HistoryRecord> history_since(std::uint64_t generation, std::size_t max) const;
  TableCounts counts() const;

  // Events after `generation`, waiting up to `timeout` for the first one. Returns
  // at once when there are some, when there is a gap, or after close().
  EventsSince wait_events(std::uint64_t generation, std::chrono::milliseconds timeout) const;

  // Runs each hook (on the writing thread, after the lock is released) whenever an
  // event was logged: the API's event loops and the service's STATUS= wake on it
  // instead of waiting on the table or polling it. Once remove_change_hook returns,
  // that hook is not running and will not run again.
  using HookId = unsigned;
  HookId add_change_hook(std::function<void()> hook);
  void remove_change_hook(HookId id);

  // Wakes every waiter for good: the daemon is stopping.
  void close();
  bool closed() const;

  // Current UTC time as RFC 3339 with milliseconds, the form of first-seen/last-seen.
  static std::string now_iso8601();
  static std::string iso8601(std::chrono::system_clock::time_point t);

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::mutex hook_mutex_;  // never held with mutex_
  std::map<HookId, std::function<void()>> hooks_;
  HookId next_hook_ = 0;
  void announce();  // wakes waiters and runs the hook
  std::string gone_cutoff() const;  // now - gone_keep, as iso8601
  DeviceTable table_;
  std::map<std::string, std::map<int, nlohmann::json>> held_;  // hold(): id -> owner -> its document
  // table_.generation(), readable without the lock: the API asks it for every request.
  std::atomic<std::uint64_t> generation_;
  bool closed_ = false;
};

}  // namespace rsd
