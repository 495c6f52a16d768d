// The local USB source's owner, as DomainSet is the DDS domains': main starts it
// with the configuration, a reload turns it on or off live, and the API reads its
// status from any thread while that happens.
#pragma once

#include "service/wake_fd.hpp"
#include "status/usb_status.hpp"
#include "table/shared_table.hpp"
#include "usb/usb_source.hpp"

#include <map>
#include <memory>
#include <mutex>
#include <optional>

namespace rsd::service {

class UsbWatch {
 public:
  explicit UsbWatch(SharedTable& table, usb::UsbOptions options = usb::UsbOptions::from_environment());
  ~UsbWatch();  // stop()
  UsbWatch(const UsbWatch&) = delete;
  UsbWatch& operator=(const UsbWatch&) = delete;

  // Main thread. On: lists the cameras present into the table before it returns,
  // then follows hotplug; without USB access it logs why and reports
  // "unavailable" (the daemon carries on). Off: stops watching and takes the USB
  // devices out of the table. Returns whether anything changed.
  bool apply(bool on);
  void stop() { apply(false); }
  bool on() const { return source_ != nullptr; }  // main thread

  // Readable when cameras() changed (an eventfd the main loop polls beside the
  // signalfd); changed() reads it: whether they did since the last call. Main thread.
  int fd() const { return wake_.fd(); }
  bool changed() { return wake_.take(); }

  // Any thread (API workers). Nothing while USB is off.
  std::optional<UsbStatus> status() const;
  // The local cameras (sighting id -> document); empty while USB is off.
  std::map<std::string, nlohmann::json> cameras() const;

 private:
  SharedTable& table_;
  usb::UsbOptions options_;
  WakeFd wake_;
  // Only the main thread replaces it, under the mutex; readers copy it under the
  // mutex and ask it outside, so a status request never waits for a stop.
  mutable std::mutex mutex_;
  std::shared_ptr<usb::UsbSource> source_;
};

}  // namespace rsd::service
