// rsd-bench-client-list: in-process list of the daemon's devices through the client
// library (rsdiscovery::Client::list), timed call by call, for bench/run.
//
//   rsd-bench-client-list ENDPOINT [ITERATIONS] [WARMUP]
//
// One Client, kept; WARMUP untimed calls first; then ITERATIONS timed calls. Prints one
// JSON object: devices, iterations, and microseconds (min, p10, median, p90, p99, max).
#include <rsdiscovery/rsdiscovery.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s ENDPOINT [ITERATIONS] [WARMUP]\n", argv[0]);
    return 2;
  }
  const int iterations = argc > 2 ? std::atoi(argv[2]) : 2000;
  const int warmup = argc > 3 ? std::atoi(argv[3]) : 50;
  try {
    rsdiscovery::Client client{std::string(argv[1])};
    std::size_t devices = 0;
    for (int i = 0; i < warmup; i++) devices = client.list().devices.size();
    std::vector<double> us;
    us.reserve(static_cast<std::size_t>(iterations));
    for (int i = 0; i < iterations; i++) {
      const auto t0 = std::chrono::steady_clock::now();
      const auto list = client.list();
      const auto t1 = std::chrono::steady_clock::now();
      devices = list.devices.size();
      us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    }
    std::sort(us.begin(), us.end());
    auto at = [&](double p) { return us.empty() ? -1.0 : us[static_cast<std::size_t>(p * double(us.size() - 1) + 0.5)]; };
    std::printf(
        "{\"devices\": %zu, \"iterations\": %d, \"min_us\": %.2f, \"p10_us\": %.2f, \"median_us\": %.2f, "
        "\"p90_us\": %.2f, \"p99_us\": %.2f, \"max_us\": %.2f}\n",
        devices, iterations, at(0), at(0.10), at(0.50), at(0.90), at(0.99), at(1.0));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rsd-bench-client-list: %s\n", e.what());
    return 1;
  }
  return 0;
}
