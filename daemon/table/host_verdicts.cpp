// The table's side of "hung or gone": the verdict on a lease-expired camera's host,
// which comes after its removal (the host is probed then), joins that removal's
// history record and gone entry.
#include "table/device_table.hpp"

#include <algorithm>

namespace rsd {

bool DeviceTable::judge_host(const std::string& entry_id, std::uint64_t removal, model::HostVerdict verdict) {
  ++counts_.hosts[static_cast<std::size_t>(verdict)];
  bool kept = false;
  if (const auto gone = gone_.find(entry_id); gone != gone_.end() && gone->second.generation == removal) {
    gone->second.host = verdict;
    kept = true;
  }
  if (const auto c = cameras_.find(entry_id); c != cameras_.end()) {
    auto& changes = c->second.changes;
    const auto it = std::lower_bound(changes.begin(), changes.end(), removal,
                                     [](const HistoryRecord& r, std::uint64_t g) { return r.generation < g; });
    if (it != changes.end() && it->generation == removal) {
      it->host = verdict;
      kept = true;
    }
  }
  return kept;
}

}  // namespace rsd
