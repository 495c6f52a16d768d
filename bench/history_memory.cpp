// What the table's memory of cameras (history, gone entries) costs: heap in use
// (mallinfo2) after cameras come and go, per camera, and whether 10,000 cameras
// churning for rounds stay within the bounds (heap flat once the caps are reached).
// Run by hand: build/bench/rsd-bench-history-memory
#include "table/device_table.hpp"

#include <malloc.h>

#include <cstdio>
#include <string>

namespace {

std::size_t heap_in_use() {
  malloc_trim(0);
  return mallinfo2().uordblks;
}

// A device-info as realdds announces a D555, with what the daemon adds.
nlohmann::json camera(int i) {
  const std::string serial = std::to_string(555000000 + i);
  return {{"name", "Intel RealSense D555"}, {"serial", serial}, {"product-line", "D500"}, {"product-id", "0B56"},
          {"fw-version", "7.56.19829.840"}, {"topic-root", "realsense/D555_" + serial}, {"source", "dds"},
          {"domain", 0}, {"recovery", false},
          {"server", {{"participant-guid", "010f1234.5678abcd.00000000.000001c1"}, {"participant-name", "cam-host"},
                      {"addresses", {"192.168.11.55"}}, {"writer-guid", "010f1234.5678abcd.00000000.00000103"}}}};
}

void churn(rsd::DeviceTable& t, int cameras, int first) {
  for (int i = first; i < first + cameras; ++i) {
    const std::string id = "dds-0-realsense.D555_" + std::to_string(555000000 + i);
    t.upsert(id, camera(i), "2026-12-04T00:00:00Z");
    t.remove(id, rsd::model::RemovalReason::lease_expired, "2026-12-04T00:00:01Z");
  }
}

}  // namespace

int main() {
  const rsd::HistoryLimits defaults;
  std::printf("limits: %zu changes a camera, %zu in all, %zu gone\n", defaults.per_camera, defaults.total,
              defaults.gone);
  for (const int n : {100, 1000}) {  // within the gone cap: every camera is kept
    const std::size_t before = heap_in_use();
    rsd::DeviceTable t;
    churn(t, n, 0);
    const std::size_t after = heap_in_use();
    std::printf("%5d cameras gone, kept: %zu B a camera (history %zu changes, %zu gone)\n", n, (after - before) / n,
                t.history_size(), t.gone_size());
  }
  rsd::DeviceTable t;
  const std::size_t base = heap_in_use();
  for (int round = 0; round < 5; ++round) {
    churn(t, 10000, round * 10000);
    std::printf("round %d: 10,000 more cameras came and went: heap %+zd KiB, history %zu, gone %zu\n", round + 1,
                static_cast<long>(heap_in_use() - base) / 1024, t.history_size(), t.gone_size());
  }
}
