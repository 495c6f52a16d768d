// What the USB source reports about itself, for /healthz, /metrics and STATUS=.
// A plain value, like DomainStatus: the source fills it, the frontends show it.
#pragma once

#include <cstdint>
#include <string>

namespace rsd {

struct UsbStatus {
  // "stopped" (not started, or stopped), "unavailable" (no USB access here: see
  // error), "hotplug" (libusb hotplug events), "polling" (re-enumerating).
  std::string state = "stopped";
  std::string error;
  std::size_t devices = 0;       // RealSense devices on USB now
  std::uint64_t arrived = 0;     // arrivals taken into the table
  std::uint64_t left = 0;        // departures taken out of it
  std::uint64_t ignored = 0;     // Intel devices that are not RealSense cameras

  // USB is being watched (STATUS= names it only then).
  bool watching() const { return state == "hotplug" || state == "polling"; }
};

}  // namespace rsd
