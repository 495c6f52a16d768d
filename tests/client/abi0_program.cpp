// A program of librsdiscovery0's users, built by test_abi0.py against the earlier
// header (DeviceFilter without `host`) and against today's, and run on today's
// shared library: every call that takes a DeviceFilter or WatchOptions, each with a
// filter and the members after it set, one JSON line of what it got.
//   abi0_program ENDPOINT DOMAIN SERIAL
#include <rsdiscovery/rsdiscovery.hpp>

#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>

namespace {

void print(const char* call, const std::vector<rsdiscovery::Device>& devices, const std::string& more = "") {
  std::string ids;
  for (const auto& d : devices) ids += (ids.empty() ? "\"" : ",\"") + d.id + "\"";
  std::printf("{\"call\":\"%s\",\"ids\":[%s]%s}\n", call, ids.c_str(), more.c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) return 2;
  using std::chrono::milliseconds;
  const int domain = std::atoi(argv[2]);
  const std::string serial = argv[3];
  try {
    rsdiscovery::Client client(argv[1]);
    rsdiscovery::DeviceFilter on_domain;
    on_domain.domain = domain;
    on_domain.source = "dds";
    print("list", client.list(on_domain).devices);
    print("list_devices", client.list_devices(on_domain));
    rsdiscovery::DeviceFilter by_serial;
    by_serial.serial = serial;
    auto got = client.wait_until(
        by_serial, [](const std::vector<rsdiscovery::Device>& v) { return !v.empty(); }, milliseconds(10000));
    print("wait_until", got ? *got : std::vector<rsdiscovery::Device>{});

    // The members after the filter are read too: on_status, last in the struct, is told.
    std::atomic<int> told{0};
    rsdiscovery::WatchOptions options;
    options.initial = true;
    options.filter.domains = {domain};
    options.reconnect = false;
    options.idle_timeout = milliseconds(30000);
    options.on_status = [&told](const rsdiscovery::WatchStatus& s) {
      if (s.connected) ++told;
    };
    auto watch = client.watch(options);
    std::vector<rsdiscovery::Device> events;
    while (auto e = watch.next(milliseconds(2000))) events.push_back(e->device);
    print("watch", events, ",\"told\":" + std::to_string(told.load()));
    watch.stop();

    auto view = client.view(options);
    print("view", view.devices());
    view.stop();

    std::mutex mutex;
    std::condition_variable arrived;
    std::vector<rsdiscovery::Device> pushed;
    rsdiscovery::WatchOptions push;
    push.initial = true;
    push.filter = by_serial;
    auto sub = client.watch(
        [&](const rsdiscovery::Event& e) {
          std::lock_guard lock(mutex);
          pushed.push_back(e.device);
          arrived.notify_all();
        },
        push);
    {
      std::unique_lock lock(mutex);
      arrived.wait_for(lock, milliseconds(10000), [&] { return !pushed.empty(); });
    }
    sub.stop();
    print("subscribe", pushed);
  } catch (const rsdiscovery::Error& e) {
    std::fprintf(stderr, "abi0_program: %s\n", e.what());
    return 3;
  }
  return 0;
}
