// What one device-info sample costs on its way from the DDS reader into the table, in
// one process with no DDS: the bytes parsed and handed to DomainBook::sample, as the
// domain session does, for 1,000 cameras of realdds-sized device-info. Two cases, as
// they come in the field: a re-announcement that changes nothing (a server answering
// a new reader), and one that changes the camera (its firmware). Prints the median and
// p90 per sample; run by hand before and after a change to the book or the table.
//
//   rsd-bench-book-samples [ROUNDS]   (default 20)
#include "dds/device_info.hpp"
#include "dds/domain_book.hpp"
#include "log/log.hpp"
#include "table/shared_table.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

constexpr int kCameras = 1000;

// A realdds camera's device-info as it is on the wire.
std::vector<std::uint8_t> device_info(int i, int fw) {
  const std::string n = std::to_string(i);
  const nlohmann::json doc = {{"name", "Intel RealSense D455"},
                              {"serial", "1236222707" + n},
                              {"product-line", "D400"},
                              {"product-id", "0B5C"},
                              {"fw-version", "5.16.0." + std::to_string(fw)},
                              {"topic-root", "realsense/D455_" + n}};
  const std::string text = doc.dump();
  return {text.begin(), text.end()};
}

// Nanoseconds per sample over one pass of every camera.
double pass(rsd::dds::DomainBook& book, int fw) {
  std::vector<std::vector<std::uint8_t>> wire;
  wire.reserve(kCameras);
  for (int i = 0; i < kCameras; ++i) wire.push_back(device_info(i, fw));
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < kCameras; ++i)
    book.sample(static_cast<rsd::dds::WriterHandle>(i + 1), rsd::dds::parse_device_info(0, wire[i]));
  const auto elapsed = std::chrono::steady_clock::now() - start;
  return std::chrono::duration<double, std::nano>(elapsed).count() / kCameras;
}

void report(const char* what, std::vector<double> ns) {
  std::sort(ns.begin(), ns.end());
  std::printf("%-40s median %8.0f ns  p90 %8.0f ns  (%zu passes of %d)\n", what, ns[ns.size() / 2],
              ns[ns.size() * 9 / 10], ns.size(), kCameras);
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::max(1, std::atoi(argv[1])) : 20;
  rsd::log::set_level(rsd::log::Level::warning);  // a line per camera added is not what is measured
  rsd::SharedTable table;
  rsd::dds::BookOptions options;
  options.max_devices_per_domain = kCameras * 2;
  options.max_devices_per_participant = kCameras * 2;
  options.max_writers_per_domain = kCameras * 2;
  options.max_writers_per_participant = kCameras * 2;
  rsd::dds::DomainBook book(table, options);
  const auto now = rsd::dds::DomainBook::Clock::now();
  for (int i = 0; i < kCameras; ++i) {
    const std::string n = std::to_string(1000000 + i);
    book.writer_matched(static_cast<rsd::dds::WriterHandle>(i + 1),
                        {"01.0f.a1.b2.00.00.00.01.00.00.00.00|" + n, "01.0f.a1.b2.00.00.00.01.00.00.00.00|1c1",
                         "realsense-server", {"10.0.0.7"}},
                        now);
  }
  pass(book, 0);  // every camera added
  std::vector<double> same, changed;
  for (int r = 0; r < rounds; ++r) same.push_back(pass(book, 0));
  for (int r = 0; r < rounds; ++r) changed.push_back(pass(book, r + 1));
  if (table.snapshot().devices.size() != static_cast<std::size_t>(kCameras)) {
    std::fprintf(stderr, "expected %d cameras in the table, got %zu\n", kCameras, table.snapshot().devices.size());
    return 1;
  }
  report("re-announced, nothing changed", same);
  report("announced with a change (fw-version)", changed);
  return 0;
}
