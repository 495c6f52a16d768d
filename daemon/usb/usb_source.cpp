#include "usb/usb_source.hpp"

#include "log/log.hpp"
#include "usb/realsense_ids.hpp"
#include "usb/usb_device.hpp"

#include <libusb.h>
#include <sys/stat.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <utility>

namespace rsd::usb {

UsbOptions UsbOptions::from_environment() {
  UsbOptions o;
  if (const char* v = std::getenv("RSD_USB_FORCE_POLLING"); v && std::string(v) == "1")
    o.force_polling = true;
  if (const char* v = std::getenv("RSD_USB_POLL_MS")) {
    const long ms = std::strtol(v, nullptr, 10);
    if (ms >= 10 && ms <= 60000) o.poll_interval = std::chrono::milliseconds(ms);
  }
  return o;
}

struct UsbSource::Impl {
  // (bus, address): what identifies a device on the bus while it is plugged in;
  // libusb still tells both for a device that has just left.
  using Key = std::pair<std::uint8_t, std::uint8_t>;

  SharedTable& table;
  UsbOptions options;
  libusb_context* ctx = nullptr;
  libusb_hotplug_callback_handle hotplug_handle{};
  bool hotplug = false;
  std::thread thread;
  std::atomic<bool> stopping{false};

  mutable std::mutex mutex;  // guards everything below; taken before the table's
  std::condition_variable wake;  // polling mode: stop() wakes the sleeper
  std::map<Key, std::string> known;  // device on the bus -> its sighting id
  std::map<std::string, nlohmann::json> docs;  // sighting id -> its document (what share-usb announces)
  UsbStatus status;
  std::function<void()> changed;  // cameras() changed
  std::chrono::steady_clock::time_point nodes_refreshed{};

  Impl(SharedTable& t, UsbOptions o, std::function<void()> c)
      : table(t), options(std::move(o)), changed(std::move(c)) {}

  void tell() {
    if (changed) changed();
  }

  static int LIBUSB_CALL on_hotplug(libusb_context*, libusb_device* dev,
                                    libusb_hotplug_event event, void* user) {
    auto* self = static_cast<Impl*>(user);
    if (event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED)
      self->arrived(dev);
    else if (event == LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT)
      self->left(key_of(dev));
    return 0;  // stay registered
  }

  static Key key_of(libusb_device* dev) {
    return {libusb_get_bus_number(dev), libusb_get_device_address(dev)};
  }

  void arrived(libusb_device* dev) {
    libusb_device_descriptor desc{};
    if (libusb_get_device_descriptor(dev, &desc) != LIBUSB_SUCCESS) return;
    if (desc.idVendor != kIntelVid) return;
    std::lock_guard lock(mutex);
    const ProductInfo* product = find_product(desc.idVendor, desc.idProduct);
    if (!product) {
      ++status.ignored;
      return;
    }
    UsbSighting s;
    s.vid = desc.idVendor;
    s.pid = desc.idProduct;
    s.bcd_usb = desc.bcdUSB;
    s.bus = libusb_get_bus_number(dev);
    s.address = libusb_get_device_address(dev);
    std::uint8_t ports[8];  // USB allows 7 tiers below the root
    const int n = libusb_get_port_numbers(dev, ports, sizeof ports);
    if (n > 0) s.ports.assign(ports, ports + n);
    const SysfsInfo sys = read_sysfs(options.sysfs_root, s.bus, s.ports, s.address);
    if (sys.matches) {
      s.serial = sys.serial;
      s.speed_mbps = sys.speed_mbps;
      s.sysfs_path = sys.path;
      s.device_nodes = device_nodes(sys.path, s.bus, s.address);
    }
    if (s.speed_mbps <= 0) {
      switch (libusb_get_device_speed(dev)) {
        case LIBUSB_SPEED_LOW: s.speed_mbps = 1.5; break;
        case LIBUSB_SPEED_FULL: s.speed_mbps = 12; break;
        case LIBUSB_SPEED_HIGH: s.speed_mbps = 480; break;
        case LIBUSB_SPEED_SUPER: s.speed_mbps = 5000; break;
        case LIBUSB_SPEED_SUPER_PLUS: s.speed_mbps = 10000; break;
        default: break;
      }
    }
    const Key key{s.bus, s.address};
    std::string id = sighting_id(s);
    // Two devices with one serial (it happens with some firmware): the second one
    // is told apart by its port rather than hiding the first.
    for (const auto& [k, other] : known)
      if (k != key && other == id) id += "-" + url_safe(port_path(s.bus, s.ports));
    if (auto it = known.find(key); it != known.end() && it->second != id) {
      table.remove(it->second, model::RemovalReason::unplugged);  // a new device at an address we missed leaving
      docs.erase(it->second);
      known.erase(it);
    }
    nlohmann::json doc = to_json(s, *product);
    const bool is_new = known.emplace(key, id).second;
    auto& kept = docs[id];
    if (kept != doc) {
      kept = doc;
      tell();
    }
    table.upsert(id, doc);
    if (!is_new) return;
    ++status.arrived;
    status.devices = known.size();
    log::info("usb: " + id + " arrived: " + doc.value("name", "") + " on " +
              port_path(s.bus, s.ports) + " at " + speed_name(s.speed_mbps) + " speed" +
              (sys.matches ? "" : " (no sysfs entry: no serial)"));
    if (auto w = link_warning(s, *product)) log::warning("usb: " + id + ": " + *w);
  }

  void left(Key key) {
    std::lock_guard lock(mutex);
    auto it = known.find(key);
    if (it == known.end()) return;  // not ours, or a LEFT without ARRIVED
    table.remove(it->second, model::RemovalReason::unplugged);
    docs.erase(it->second);
    tell();
    log::info("usb: " + it->second + " left (unplugged)");
    known.erase(it);
    ++status.left;
    status.devices = known.size();
  }

  // A camera's video, media and hidraw nodes come when its interfaces' drivers
  // bind, after libusb tells it arrived (and go when they unbind): looked for
  // again about every second, and changed in the table only when they differ.
  void refresh_nodes() {
    const auto now = std::chrono::steady_clock::now();
    std::lock_guard lock(mutex);
    if (now - nodes_refreshed < std::chrono::seconds(1)) return;
    nodes_refreshed = now;
    for (auto& [id, doc] : docs) {
      model::Device d = model::device_from_json(doc);
      if (!d.usb || !d.usb->sysfs_path) continue;
      auto nodes = device_nodes(*d.usb->sysfs_path, static_cast<std::uint8_t>(d.usb->bus),
                                static_cast<std::uint8_t>(d.usb->address));
      if (nodes.empty() || nodes == d.usb->device_nodes) continue;  // empty: leaving
      d.usb->device_nodes = std::move(nodes);
      doc = model::to_json(d);
      table.upsert(id, doc);
      tell();
    }
  }

  // One enumeration, compared with what we know: polling mode.
  void rescan() {
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(ctx, &list);
    if (n < 0) return;
    std::set<Key> present;
    for (ssize_t i = 0; i < n; ++i) {
      libusb_device_descriptor desc{};
      if (libusb_get_device_descriptor(list[i], &desc) != LIBUSB_SUCCESS) continue;
      if (desc.idVendor != kIntelVid) continue;
      const Key key = key_of(list[i]);
      present.insert(key);
      bool seen = false;
      {
        std::lock_guard lock(mutex);
        seen = known.count(key) > 0;
      }
      if (!seen) arrived(list[i]);
    }
    libusb_free_device_list(list, 1);
    std::vector<Key> gone;
    {
      std::lock_guard lock(mutex);
      for (const auto& [k, id] : known)
        if (!present.count(k)) gone.push_back(k);
    }
    for (const auto& k : gone) left(k);
    refresh_nodes();
  }

  void unavailable(const std::string& why) {
    {
      std::lock_guard lock(mutex);
      status.state = "unavailable";
      status.error = why;
    }
    log::warning("usb: local USB cameras are not listed: " + why + "; DDS discovery carries on");
  }
};

UsbSource::UsbSource(SharedTable& table, UsbOptions options, std::function<void()> changed)
    : impl_(std::make_unique<Impl>(table, std::move(options), std::move(changed))) {}

UsbSource::~UsbSource() { stop(); }

bool UsbSource::start() {
  auto& d = *impl_;
  if (d.ctx) return true;
  struct stat st{};
  if (::stat(d.options.usbfs_path.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    d.unavailable("no " + d.options.usbfs_path + " (a container without USB devices passed in?)");
    return false;
  }
  if (const int rc = libusb_init(&d.ctx); rc != LIBUSB_SUCCESS) {
    d.ctx = nullptr;
    d.unavailable(std::string("libusb cannot start: ") + libusb_strerror(rc));
    return false;
  }
  d.stopping = false;
  d.hotplug = !d.options.force_polling && libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG);
  if (d.hotplug) {
    // ENUMERATE: the devices present now arrive here, on this thread, before
    // registering returns; later ones on the event thread.
    const int rc = libusb_hotplug_register_callback(
        d.ctx, LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT,
        LIBUSB_HOTPLUG_ENUMERATE, kIntelVid, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY,
        &Impl::on_hotplug, &d, &d.hotplug_handle);
    if (rc != LIBUSB_SUCCESS) {
      log::notice(std::string("usb: hotplug registration failed (") + libusb_strerror(rc) +
                  "): re-enumerating instead");
      d.hotplug = false;
    }
  }
  {
    std::lock_guard lock(d.mutex);
    d.status.state = d.hotplug ? "hotplug" : "polling";
    d.status.error.clear();
  }
  if (d.hotplug) {
    d.thread = std::thread([&d] {
      while (!d.stopping) {
        timeval tv{1, 0};
        libusb_handle_events_timeout_completed(d.ctx, &tv, nullptr);
        d.refresh_nodes();
      }
    });
    log::info("usb: watching for RealSense cameras (libusb hotplug)");
  } else {
    if (!d.options.force_polling)
      log::notice("usb: libusb has no hotplug support here: re-enumerating every " +
                  std::to_string(d.options.poll_interval.count()) + " ms");
    else
      log::info("usb: re-enumerating every " + std::to_string(d.options.poll_interval.count()) +
                " ms (polling forced)");
    d.rescan();
    d.thread = std::thread([&d] {
      std::unique_lock lock(d.mutex);
      while (!d.stopping) {
        d.wake.wait_for(lock, d.options.poll_interval, [&d] { return d.stopping.load(); });
        if (d.stopping) break;
        lock.unlock();
        d.rescan();
        lock.lock();
      }
    });
  }
  return true;
}

void UsbSource::stop() {
  auto& d = *impl_;
  if (!d.ctx) return;
  {
    std::lock_guard lock(d.mutex);
    d.stopping = true;
  }
  d.wake.notify_all();
  if (d.hotplug) libusb_interrupt_event_handler(d.ctx);
  if (d.thread.joinable()) d.thread.join();
  if (d.hotplug) libusb_hotplug_deregister_callback(d.ctx, d.hotplug_handle);
  {
    std::lock_guard lock(d.mutex);
    // Not unplugged: the daemon stopped watching USB (a reload, or its stop).
    for (const auto& [key, id] : d.known) d.table.remove(id, model::RemovalReason::domain_left);
    d.known.clear();
    if (!d.docs.empty()) d.tell();
    d.docs.clear();
    d.status.devices = 0;
    d.status.state = "stopped";
  }
  libusb_exit(d.ctx);
  d.ctx = nullptr;
}

std::map<std::string, nlohmann::json> UsbSource::cameras() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->docs;
}

UsbStatus UsbSource::status() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->status;
}

}  // namespace rsd::usb
