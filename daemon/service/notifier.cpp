#include "service/notifier.hpp"

#include "log/log.hpp"

#include <systemd/sd-daemon.h>

#include <cstdlib>
#include <cstring>
#include <ctime>

namespace rsd::service {

Notifier::Notifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  active_ = socket && *socket;
  std::uint64_t usec = 0;
  // > 0 only when WATCHDOG_USEC is set and WATCHDOG_PID (if set) is our pid.
  if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0) watchdog_ = std::chrono::microseconds(usec);
}

bool Notifier::send(const std::string& state) {
  if (!active_) return false;
  const int rc = sd_notify(0, state.c_str());
  if (rc > 0) return true;
  if (!warned_) {
    warned_ = true;
    log::debug(std::string("service: cannot notify the service manager: ") +
               (rc < 0 ? std::strerror(-rc) : "NOTIFY_SOCKET not usable"));
  }
  return false;
}

std::string reloading_message() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  const auto usec = static_cast<std::uint64_t>(ts.tv_sec) * 1000000u + static_cast<std::uint64_t>(ts.tv_nsec) / 1000u;
  return "RELOADING=1\nMONOTONIC_USEC=" + std::to_string(usec);
}

}  // namespace rsd::service
