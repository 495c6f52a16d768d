// A micro-benchmark of the device table's read paths as the API serves them, in one
// process with no socket (ApiServer::answer): 1,000 DDS devices with realdds-sized
// device-info, and after every change (the list cache then misses) a filtered list,
// a lookup by serial and the unfiltered list; and what the change itself costs the
// writer (an upsert that changes a device, one that only moves last-seen). Prints the
// median and p90 of each.
//
//   rsd-bench-table-reads [ROUNDS]   (default 300)
#include "api/api_server.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <malloc.h>

namespace {

class NoStatus final : public rsd::StatusView {
 public:
  std::vector<rsd::DomainStatus> domains() const override { return {}; }
  std::vector<rsd::model::Participant> participants() const override { return {}; }
  std::optional<rsd::UsbStatus> usb() const override { return std::nullopt; }
  rsd::DeviceDescription describe(const std::string&) const override {
    return {rsd::DeviceDescription::Outcome::not_found, {}, "none"};
  }
};

// What a realdds camera's entry looks like: the daemon's keys and the camera's own
// device-info keys beside them.
nlohmann::json device(int i, int fw) {
  const std::string n = std::to_string(i);
  return {{"source", "dds"},
          {"domain", i % 4},
          {"topic-root", "realsense/D455_" + n},
          {"name", (i % 2 ? "Intel RealSense D455 " : "Intel RealSense D555 ") + n},
          {"serial", "1234567" + n},
          {"product-line", i % 2 ? "D400" : "D500"},
          {"product-id", "0B5C"},
          {"fw-version", "5.16.0." + std::to_string(fw)},
          {"recovery", false},
          {"server",
           {{"participant-guid", "01.0f.aa.bb.cc.dd." + n},
            {"participant-name", "realsense-camera-" + n},
            {"addresses", {"192.168.1." + std::to_string(i % 250), "fe80::1:" + n}},
            {"writer-guid", "01.0f.aa.bb.cc.dd." + n + ".1.3"}}},
          {"type", "D455"},
          {"locked", true},
          {"usb-type", "3.2"},
          {"camera-firmware", {{"major", 5}, {"minor", 16}}},
          {"streams", {"Depth", "Color", "Infrared_1", "Infrared_2", "Motion"}}};
}

struct Row {
  const char* name;
  std::string request;
  std::vector<double> us;
};

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))];
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::atoi(argv[1]) : 300;
  constexpr int kDevices = 1000;
  rsd::SharedTable table;
  NoStatus status;
  rsd::api::ApiServer api(table, status, "bench");
  for (int i = 0; i < kDevices; ++i) table.upsert("dds/" + std::to_string(i), device(i, 1));
  const auto heap_filled = mallinfo2().uordblks;

  auto get = [](const std::string& target) { return "GET " + target + " HTTP/1.1\r\nHost: localhost\r\n\r\n"; };
  std::vector<Row> rows = {
      {"filtered list (?domain=1&product-line=d400, 250 of 1000)", get("/v1/devices?domain=1&product-line=d400"), {}},
      {"filtered list (?name=d555&address=192.168.1.7)", get("/v1/devices?name=d555&address=192.168.1.7"), {}},
      {"lookup by serial (/v1/devices/1234567500)", get("/v1/devices/1234567500"), {}},
      {"unfiltered list (1000 devices)", get("/v1/devices"), {}},
  };
  Row changed{"upsert, a change (the writer's cost)", {}, {}};
  Row same{"upsert, the same device again (last-seen only)", {}, {}};
  auto timed = [](Row& row, auto&& f) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    row.us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
  };
  std::size_t bytes = 0;
  for (int r = 0; r < rounds; ++r) {
    // A change first: every request below misses the per-generation list cache.
    const int i = r % kDevices;
    auto doc = device(i, 2 + r);
    timed(changed, [&] { table.upsert("dds/" + std::to_string(i), doc); });
    timed(same, [&] { table.upsert("dds/" + std::to_string(i), doc); });
    for (auto& row : rows) {
      const auto t0 = std::chrono::steady_clock::now();
      const auto answer = api.answer(row.request, false);
      const auto t1 = std::chrono::steady_clock::now();
      if (answer.compare(0, 15, "HTTP/1.1 200 OK") != 0) {
        std::fprintf(stderr, "%s: %.80s\n", row.name, answer.c_str());
        return 1;
      }
      bytes += answer.size();
      row.us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    }
  }
  // After the rounds the change log is full (its 128 KiB of text): what it holds
  // besides the table shows here.
  const auto heap_after = mallinfo2().uordblks;
  std::printf("%d devices, %d rounds (a change before each round), %zu bytes answered\n", kDevices, rounds, bytes);
  std::printf("  heap in use: %.1f MiB with the table filled, %.1f MiB after the rounds\n",
              static_cast<double>(heap_filled) / (1 << 20), static_cast<double>(heap_after) / (1 << 20));
  rows.push_back(std::move(changed));
  rows.push_back(std::move(same));
  for (const auto& row : rows)
    std::printf("  %-60s median %8.1f us  p90 %8.1f us\n", row.name, percentile(row.us, 0.5),
                percentile(row.us, 0.9));
  return 0;
}
