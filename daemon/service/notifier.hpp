// The service manager's notification socket (sd_notify(3)), through libsystemd.
// Without NOTIFY_SOCKET (started by hand) every call is a no-op.
#pragma once

#include <chrono>
#include <optional>
#include <string>

namespace rsd::service {

class Notifier {
 public:
  // Reads NOTIFY_SOCKET and WATCHDOG_USEC/WATCHDOG_PID once; the variables stay
  // set, since the socket is used for the whole life of the process.
  Notifier();

  bool active() const { return active_; }
  // The watchdog timeout the unit asked for (WatchdogSec=), if it is for us.
  std::optional<std::chrono::microseconds> watchdog() const { return watchdog_; }

  // One datagram of newline-separated assignments ("READY=1\nSTATUS=...").
  // Returns false (and logs once at debug) when it cannot be sent.
  bool send(const std::string& state);

 private:
  bool active_ = false;
  std::optional<std::chrono::microseconds> watchdog_;
  bool warned_ = false;
};

// "RELOADING=1\nMONOTONIC_USEC=<now>": the form systemd documents for reloads.
std::string reloading_message();

}  // namespace rsd::service
