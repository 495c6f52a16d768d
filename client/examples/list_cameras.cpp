// Lists the RealSense cameras that rs-discoveryd knows, then waits (up to 5 s) for a
// D400 camera if none is there yet. Build against the installed library with
//   c++ -std=c++17 list_cameras.cpp $(pkg-config --cflags --libs rsdiscovery)
// or find_package(rsdiscovery) and target_link_libraries(... rsdiscovery::rsdiscovery).
#include <rsdiscovery/rsdiscovery.hpp>

#include <cstdio>

int main(int argc, char** argv) {
  try {
    // The default endpoint: $RS_DISCOVERY_ENDPOINT, else the daemon's default socket.
    rsdiscovery::Client client(argc > 1 ? argv[1] : "");
    auto devices = client.list_devices();
    std::printf("%zu camera(s) at %s\n", devices.size(), client.endpoint().to_string().c_str());
    for (const auto& d : devices) {
      std::printf("  %-24s serial %-14s %s", d.name.c_str(), d.serial.c_str(), d.source.c_str());
      if (d.domain) std::printf(" domain %d", *d.domain);
      if (d.server && !d.server->addresses.empty()) std::printf(" at %s", d.server->addresses[0].c_str());
      std::printf("\n");
    }
    if (devices.empty()) {
      auto d400 = client.wait_for([](const rsdiscovery::Device& d) { return d.product_line == "D400"; },
                                  std::chrono::seconds(5));
      if (d400) std::printf("a D400 appeared: %s (%s)\n", d400->name.c_str(), d400->id.c_str());
    }
    return 0;
  } catch (const rsdiscovery::Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return e.code() == rsdiscovery::ErrorCode::not_running ? 3 : 1;
  }
}
