// A test driver of the rsdiscovery library for pytest:
//   rsdiscovery_test_driver subscribe ENDPOINT      callback watch; one JSON line per event
//                                                   on stdout until stdin closes
//   rsdiscovery_test_driver wait-for ENDPOINT SERIAL SECONDS
//                                                   prints the device id, or exits 1
//   rsdiscovery_test_driver view ENDPOINT            a DeviceView; each line on stdin is a
//                                                   command: "list" prints the view's devices
//                                                   ({"connected":..,"devices":[document..]})
//                                                   or the Error devices() threw; "stop" stops
//                                                   the view; the input's end ends it
//   rsdiscovery_test_driver describe ENDPOINT ID    prints the typed Description back as
//                                                   JSON (from the struct's members, not its
//                                                   json); an Error: its code and status, exit 3
#include <rsdiscovery/rsdiscovery.hpp>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <string>

namespace {

std::mutex out_mutex;

void line(const std::string& text) {
  std::lock_guard lock(out_mutex);
  std::fputs((text + "\n").c_str(), stdout);
  std::fflush(stdout);
}

std::string quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) return 2;
  std::string mode = argv[1];
  try {
    rsdiscovery::Client client(argv[2]);
    if (mode == "subscribe") {
      rsdiscovery::WatchOptions options;
      options.initial(true);
      auto sub = client.watch(
          [](const rsdiscovery::Event& e) {
            line(std::string("{\"event\":\"") + rsdiscovery::to_string(e.type) + "\",\"id\":" + std::to_string(e.id) +
                 ",\"synthetic\":" + (e.synthetic ? "true" : "false") + ",\"device\":" + e.device.json + "}");
          },
          options, [](std::exception_ptr) { line("{\"error\":true}"); },
          [](const rsdiscovery::WatchStatus& s) {
            line(std::string("{\"status\":") + (s.connected ? "\"connected\"" : "\"disconnected\"") +
                 ",\"message\":" + quote(s.message) + "}");
          });
      line("{\"ready\":true}");
      std::string ignored;
      while (std::getline(std::cin, ignored)) {
      }
      sub.stop();
      return 0;
    }
    if (mode == "view") {
      auto view = client.view();
      line("{\"ready\":true}");
      std::string command;
      while (std::getline(std::cin, command)) {
        if (command == "stop") {
          view.stop();
          line("{\"stopped\":true}");
          continue;
        }
        try {
          std::string out = std::string("{\"connected\":") + (view.connected() ? "true" : "false") + ",\"devices\":[";
          for (const auto& d : view.devices()) out += (out.back() == '[' ? "" : ",") + d.json;
          line(out + "]}");
        } catch (const rsdiscovery::Error& e) {
          line(std::string("{\"error\":") + quote(rsdiscovery::to_string(e.code())) + ",\"message\":" +
               quote(e.what()) + "}");
        }
      }
      return 0;
    }
    if (mode == "wait-for" && argc == 5) {
      std::string serial = argv[3];
      auto ms = std::chrono::milliseconds(static_cast<long long>(std::atof(argv[4]) * 1000));
      auto d = client.wait_for([&](const rsdiscovery::Device& dev) { return dev.serial == serial; }, ms);
      if (!d) return 1;
      line(d->id);
      return 0;
    }
    if (mode == "participants") {
      for (const auto& p : client.participants()) {
        std::string addresses = "[";
        for (const auto& a : p.addresses) addresses += (addresses.size() > 1 ? "," : "") + quote(a);
        line("{\"name\":" + quote(p.name) + ",\"vendor\":" + quote(p.vendor) + ",\"state\":" + quote(p.state) +
             ",\"devices\":" + std::to_string(p.devices) + ",\"lease\":" +
             (p.lease_seconds ? std::to_string(*p.lease_seconds) : std::string("null")) + ",\"addresses\":" +
             addresses + "],\"never_announced\":" + (p.never_announced ? "true" : "false") +
             ",\"guid\":" + quote(p.guid) + "}");
      }
      return 0;
    }
    if (mode == "describe" && argc == 4) {
      const auto d = client.describe(argv[3]);
      auto profile = [](const rsdiscovery::StreamProfile& p) {
        return "[" + std::to_string(p.fps) + "," + quote(p.format) + "," + std::to_string(p.width) + "," +
               std::to_string(p.height) + "]";
      };
      auto names = [](const std::vector<rsdiscovery::CameraOption>& options) {
        std::string out = "[";
        for (const auto& o : options) out += (out.size() > 1 ? "," : "") + quote(o.name);
        return out + "]";
      };
      std::string out = "{\"streams\":[";
      for (const auto& st : d.streams) {
        if (out.back() != '[') out += ",";
        out += "{\"name\":" + quote(st.name) + ",\"type\":" + quote(st.type) + ",\"sensor\":" + quote(st.sensor) +
               ",\"profiles\":[";
        for (const auto& p : st.profiles) out += (out.back() == '[' ? "" : ",") + profile(p);
        out += "],\"default\":" + (st.default_profile ? profile(*st.default_profile) : std::string("null")) +
               ",\"metadata\":" + (st.metadata ? "true" : "false") + ",\"options\":" + names(st.options) + "}";
      }
      out += "],\"device-options\":" + names(d.device_options) + "}";
      line(out);
      return 0;
    }
  } catch (const rsdiscovery::Error& e) {
    std::fprintf(stderr, "%s %d: %s\n", rsdiscovery::to_string(e.code()), e.http_status(), e.what());
    return 3;
  }
  return 2;
}
