// UsbWatch: the USB source's lifecycle (start, reload on/off, stop).
#include "service/usb_watch.hpp"

#include "log/log.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cstdint>

namespace rsd::service {

UsbWatch::UsbWatch(SharedTable& table, usb::UsbOptions options)
    : table_(table), options_(std::move(options)), wake_fd_(eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {
  if (wake_fd_ < 0) log::error("usb: cannot create an eventfd: shared USB cameras follow plugs only on other changes");
}

UsbWatch::~UsbWatch() {
  stop();
  if (wake_fd_ >= 0) close(wake_fd_);
}

void UsbWatch::wake() {
  const std::uint64_t one = 1;
  if (wake_fd_ < 0) return;
  // Fails only when the counter is full, that is with a wake already pending.
  const ssize_t n = write(wake_fd_, &one, sizeof one);
  static_cast<void>(n);
}

bool UsbWatch::changed() {
  std::uint64_t n = 0;
  return wake_fd_ >= 0 && read(wake_fd_, &n, sizeof n) == static_cast<ssize_t>(sizeof n) && n > 0;
}

bool UsbWatch::apply(bool on) {
  if (on == (source_ != nullptr)) return false;
  if (on) {
    auto source = std::make_shared<usb::UsbSource>(table_, options_, [this] { wake(); });
    source->start();  // false: unavailable here, logged; its status says why
    std::lock_guard lock(mutex_);
    source_ = std::move(source);
    return true;
  }
  std::shared_ptr<usb::UsbSource> leaving;
  {
    std::lock_guard lock(mutex_);
    leaving = std::move(source_);
  }
  leaving->stop();  // its devices leave the table
  return true;
}

std::optional<UsbStatus> UsbWatch::status() const {
  std::shared_ptr<usb::UsbSource> source;
  {
    std::lock_guard lock(mutex_);
    source = source_;
  }
  if (!source) return std::nullopt;
  return source->status();
}

std::map<std::string, nlohmann::json> UsbWatch::cameras() const {
  std::shared_ptr<usb::UsbSource> source;
  {
    std::lock_guard lock(mutex_);
    source = source_;
  }
  if (!source) return {};
  return source->cameras();
}

}  // namespace rsd::service
