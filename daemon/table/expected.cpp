// Expected cameras against the table (expected.hpp).
#include "table/expected.hpp"

namespace rsd {

model::ExpectedReport expected_report(const std::vector<model::ExpectedCamera>& expected,
                                      const std::vector<EntryPtr>& devices, bool complete) {
  model::ExpectedReport out;
  out.complete = complete;
  for (const auto& camera : expected) {
    model::ExpectedStatus status{camera, std::nullopt, std::nullopt, std::nullopt};
    for (const auto& e : devices)
      if (e->device.named_by(camera.key())) {
        status.id = e->device.id;
        break;
      }
    (status.id ? out.present : out.missing).push_back(std::move(status));
  }
  return out;
}

model::ExpectedReport expected_report(const std::vector<model::ExpectedCamera>& expected, const SharedTable& table,
                                      bool complete) {
  if (expected.empty()) return expected_report(expected, std::vector<EntryPtr>{}, complete);
  auto report = expected_report(expected, table.snapshot().devices, complete);
  for (auto& m : report.missing)
    if (const auto gone = table.find_gone(m.camera.key())) {
      if (gone->last && gone->last->device.last_seen) m.last_seen = gone->last->device.last_seen;
      m.reason = std::string(model::to_string(gone->reason));
    }
  return report;
}

}  // namespace rsd
