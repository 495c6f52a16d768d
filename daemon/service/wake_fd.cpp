// WakeFd: the eventfd behind it.
#include "service/wake_fd.hpp"

#include "log/log.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cstdint>

namespace rsd::service {

WakeFd::WakeFd() : fd_(eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {
  if (fd_ < 0) log::error("cannot create an eventfd: the main loop follows other threads only at its timers");
}

WakeFd::~WakeFd() {
  if (fd_ >= 0) close(fd_);
}

void WakeFd::wake() const {
  if (fd_ < 0) return;
  const std::uint64_t one = 1;
  // Fails only when the counter is full, that is with a wake already pending.
  const ssize_t n = write(fd_, &one, sizeof one);
  static_cast<void>(n);
}

bool WakeFd::take() {
  std::uint64_t n = 0;
  return fd_ >= 0 && read(fd_, &n, sizeof n) == static_cast<ssize_t>(sizeof n) && n > 0;
}

}  // namespace rsd::service
