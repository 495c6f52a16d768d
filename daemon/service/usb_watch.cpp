// UsbWatch: the USB source's lifecycle (start, reload on/off, stop).
#include "service/usb_watch.hpp"

#include "log/log.hpp"

namespace rsd::service {

UsbWatch::UsbWatch(SharedTable& table, usb::UsbOptions options) : table_(table), options_(std::move(options)) {}

UsbWatch::~UsbWatch() { stop(); }

bool UsbWatch::apply(bool on) {
  if (on == (source_ != nullptr)) return false;
  if (on) {
    auto source = std::make_shared<usb::UsbSource>(table_, options_, [this] { wake_.wake(); });
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
