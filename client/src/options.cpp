// DeviceFilter, WatchOptions and ClientOptions (rsdiscovery/options.hpp): their settings
// live here, behind the pointer, so that adding one changes no layout a program saw.
// A null pointer stands for the defaults: an object never set (or moved from) costs
// no allocation and reads as new.
#include <rsdiscovery/options.hpp>

namespace rsdiscovery {
namespace {

using std::chrono::milliseconds;

template <class Impl>
const Impl& read(const std::unique_ptr<Impl>& p) {
  static const Impl defaults;
  return p ? *p : defaults;
}

template <class Impl>
Impl& write(std::unique_ptr<Impl>& p) {
  if (!p) p = std::make_unique<Impl>();
  return *p;
}

template <class Impl>
std::unique_ptr<Impl> copy(const std::unique_ptr<Impl>& p) {
  return p ? std::make_unique<Impl>(*p) : nullptr;
}

}  // namespace

// ---- DeviceFilter -------------------------------------------------------------------

struct DeviceFilter::Impl {
  std::vector<int> domains;
  std::string product_line, source, serial, name, address, host;
  std::optional<bool> in_use;
};

DeviceFilter::DeviceFilter() = default;
DeviceFilter::DeviceFilter(const DeviceFilter& other) : impl_(copy(other.impl_)) {}
DeviceFilter::DeviceFilter(DeviceFilter&&) noexcept = default;
DeviceFilter& DeviceFilter::operator=(const DeviceFilter& other) {
  if (this != &other) impl_ = copy(other.impl_);
  return *this;
}
DeviceFilter& DeviceFilter::operator=(DeviceFilter&&) noexcept = default;
DeviceFilter::~DeviceFilter() = default;

DeviceFilter& DeviceFilter::domain(int d) {
  write(impl_).domains.push_back(d);
  return *this;
}
DeviceFilter& DeviceFilter::product_line(std::string v) {
  write(impl_).product_line = std::move(v);
  return *this;
}
DeviceFilter& DeviceFilter::source(std::string v) {
  write(impl_).source = std::move(v);
  return *this;
}
DeviceFilter& DeviceFilter::serial(std::string v) {
  write(impl_).serial = std::move(v);
  return *this;
}
DeviceFilter& DeviceFilter::name(std::string v) {
  write(impl_).name = std::move(v);
  return *this;
}
DeviceFilter& DeviceFilter::address(std::string v) {
  write(impl_).address = std::move(v);
  return *this;
}
DeviceFilter& DeviceFilter::host(std::string v) {
  write(impl_).host = std::move(v);
  return *this;
}
DeviceFilter& DeviceFilter::in_use(bool v) {
  write(impl_).in_use = v;
  return *this;
}

const std::vector<int>& DeviceFilter::domains() const { return read(impl_).domains; }
const std::string& DeviceFilter::product_line() const { return read(impl_).product_line; }
const std::string& DeviceFilter::source() const { return read(impl_).source; }
const std::string& DeviceFilter::serial() const { return read(impl_).serial; }
const std::string& DeviceFilter::name() const { return read(impl_).name; }
const std::string& DeviceFilter::address() const { return read(impl_).address; }
const std::string& DeviceFilter::host() const { return read(impl_).host; }
std::optional<bool> DeviceFilter::in_use() const { return read(impl_).in_use; }

// ---- WatchOptions -------------------------------------------------------------------

struct WatchOptions::Impl {
  bool initial = false;
  std::optional<std::uint64_t> last_event_id;
  DeviceFilter filter;
  bool reconnect = true;
  milliseconds max_reconnect_delay{2000};
  milliseconds idle_timeout{60000};
  milliseconds complete_timeout{10000};
  std::function<void(const WatchStatus&)> on_status;
};

WatchOptions::WatchOptions() = default;
WatchOptions::WatchOptions(const WatchOptions& other) : impl_(copy(other.impl_)) {}
WatchOptions::WatchOptions(WatchOptions&&) noexcept = default;
WatchOptions& WatchOptions::operator=(const WatchOptions& other) {
  if (this != &other) impl_ = copy(other.impl_);
  return *this;
}
WatchOptions& WatchOptions::operator=(WatchOptions&&) noexcept = default;
WatchOptions::~WatchOptions() = default;

WatchOptions& WatchOptions::initial(bool v) {
  write(impl_).initial = v;
  return *this;
}
WatchOptions& WatchOptions::last_event_id(std::uint64_t v) {
  write(impl_).last_event_id = v;
  return *this;
}
WatchOptions& WatchOptions::filter(DeviceFilter v) {
  write(impl_).filter = std::move(v);
  return *this;
}
WatchOptions& WatchOptions::reconnect(bool v) {
  write(impl_).reconnect = v;
  return *this;
}
WatchOptions& WatchOptions::max_reconnect_delay(milliseconds v) {
  write(impl_).max_reconnect_delay = v;
  return *this;
}
WatchOptions& WatchOptions::idle_timeout(milliseconds v) {
  write(impl_).idle_timeout = v;
  return *this;
}
WatchOptions& WatchOptions::complete_timeout(milliseconds v) {
  write(impl_).complete_timeout = v;
  return *this;
}
WatchOptions& WatchOptions::on_status(std::function<void(const WatchStatus&)> v) {
  write(impl_).on_status = std::move(v);
  return *this;
}

bool WatchOptions::initial() const { return read(impl_).initial; }
std::optional<std::uint64_t> WatchOptions::last_event_id() const { return read(impl_).last_event_id; }
const DeviceFilter& WatchOptions::filter() const { return read(impl_).filter; }
bool WatchOptions::reconnect() const { return read(impl_).reconnect; }
milliseconds WatchOptions::max_reconnect_delay() const { return read(impl_).max_reconnect_delay; }
milliseconds WatchOptions::idle_timeout() const { return read(impl_).idle_timeout; }
milliseconds WatchOptions::complete_timeout() const { return read(impl_).complete_timeout; }
const std::function<void(const WatchStatus&)>& WatchOptions::on_status() const { return read(impl_).on_status; }

// ---- ClientOptions ------------------------------------------------------------------

struct ClientOptions::Impl {
  milliseconds connect_timeout{2000};
  milliseconds request_timeout{10000};
  milliseconds complete_timeout{5000};
  std::function<void(const std::string&)> on_busy;
};

ClientOptions::ClientOptions() = default;
ClientOptions::ClientOptions(const ClientOptions& other) : impl_(copy(other.impl_)) {}
ClientOptions::ClientOptions(ClientOptions&&) noexcept = default;
ClientOptions& ClientOptions::operator=(const ClientOptions& other) {
  if (this != &other) impl_ = copy(other.impl_);
  return *this;
}
ClientOptions& ClientOptions::operator=(ClientOptions&&) noexcept = default;
ClientOptions::~ClientOptions() = default;

ClientOptions& ClientOptions::connect_timeout(milliseconds v) {
  write(impl_).connect_timeout = v;
  return *this;
}
ClientOptions& ClientOptions::request_timeout(milliseconds v) {
  write(impl_).request_timeout = v;
  return *this;
}
ClientOptions& ClientOptions::complete_timeout(milliseconds v) {
  write(impl_).complete_timeout = v;
  return *this;
}
ClientOptions& ClientOptions::on_busy(std::function<void(const std::string&)> v) {
  write(impl_).on_busy = std::move(v);
  return *this;
}

milliseconds ClientOptions::connect_timeout() const { return read(impl_).connect_timeout; }
milliseconds ClientOptions::request_timeout() const { return read(impl_).request_timeout; }
milliseconds ClientOptions::complete_timeout() const { return read(impl_).complete_timeout; }
const std::function<void(const std::string&)>& ClientOptions::on_busy() const { return read(impl_).on_busy; }

}  // namespace rsdiscovery
