// The local USB source: RealSense cameras plugged into this machine, found with
// libusb (enumeration at start, then hotplug arrived/left on libusb's event
// thread; periodic re-enumeration where hotplug is unsupported) and written to
// the table as "usb" sightings. Never opens or claims a device.
#pragma once

#include "table/shared_table.hpp"
#include "usb/usb_status.hpp"

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

namespace rsd::usb {

struct UsbOptions {
  // Re-enumerate every poll_interval instead of using hotplug (also chosen when
  // libusb has no hotplug support).
  bool force_polling = false;
  std::chrono::milliseconds poll_interval{1000};
  std::string sysfs_root = "/sys";
  std::string usbfs_path = "/dev/bus/usb";  // no such directory: no USB access here

  // Defaults, overridden by RSD_USB_FORCE_POLLING=1 and RSD_USB_POLL_MS=<ms>
  // (for tests and odd hosts; not a user-facing setting).
  static UsbOptions from_environment();
};

class UsbSource {
 public:
  // `changed` is called (from libusb's thread, or the caller's in start and stop)
  // each time cameras() changes; it must only wake someone, never call back in.
  UsbSource(SharedTable& table, UsbOptions options = UsbOptions::from_environment(),
            std::function<void()> changed = {});
  ~UsbSource();  // stop()
  UsbSource(const UsbSource&) = delete;
  UsbSource& operator=(const UsbSource&) = delete;

  // Lists the cameras present now into the table, then watches for changes on one
  // thread. Returns false when USB cannot be used here (logged once, with why);
  // the daemon carries on without it. Never throws for a missing USB stack.
  bool start();

  // Stops watching and takes this source's devices out of the table. Idempotent;
  // returns within about a second.
  void stop();

  UsbStatus status() const;
  // The cameras listed now: sighting id -> the document given to the table (what
  // share-usb announces to other hosts). Any thread.
  std::map<std::string, nlohmann::json> cameras() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rsd::usb
