// What the table's memory of cameras (history, gone entries) costs: heap in use
// (mallinfo2) after cameras come and go, per camera, and whether 10,000 cameras
// churning for rounds stay within the bounds (heap flat once the caps are reached).
// Run by hand: build/bench/rsd-bench-history-memory; with --check (the suite's
// bench_history_memory_flat) it fails unless the heap after the last round is within
// a small margin of the heap after the first: memory is counted, not timed.
#include "table/device_table.hpp"

#include <malloc.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
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

int main(int argc, char** argv) {
  const bool check = argc > 1 && std::strcmp(argv[1], "--check") == 0;
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
  long first = 0, last = 0;  // heap growth after the first and the last round
  for (int round = 0; round < 5; ++round) {
    churn(t, 10000, round * 10000);
    last = static_cast<long>(heap_in_use()) - static_cast<long>(base);
    if (round == 0) first = last;
    std::printf("round %d: 10,000 more cameras came and went: heap %+ld KiB, history %zu, gone %zu\n", round + 1,
                last / 1024, t.history_size(), t.gone_size());
  }
  if (!check) return 0;
  // Flat: the caps were reached in the first round, so later rounds only replace
  // entries. The margin is allocator slack (fragmentation), not growth.
  const long margin = std::max(256L * 1024, first / 50);
  const bool flat = t.history_size() <= defaults.total && t.gone_size() <= defaults.gone && last <= first + margin;
  std::printf("%s: heap after round 5 %+ld KiB against round 1 (margin %ld KiB)\n", flat ? "flat" : "GROWING",
              (last - first) / 1024, margin / 1024);
  return flat ? 0 : 1;
}
