// librsdiscovery0's calls as programs built before DeviceFilter had `host` link them.
//
// DeviceFilter grew a member (issue 25), and WatchOptions holds one by value: a program
// built against the earlier header passes the smaller layout. The header now declares
// both types in an inline namespace (filters2), which gives the calls that take them
// new symbols; the symbols of the earlier layout are defined here, with the layout they
// were built with, and call the new ones. The soname stays librsdiscovery.so.0.
//
// Each is a free function under the earlier member function's mangled name (`asm`): in
// the Itanium C++ ABI `this` is a member function's first parameter, after the hidden
// return pointer where there is one, exactly as `self` is here. The layouts are the
// earlier header's, pinned by the sizes below; tests/client/test_abi0.py builds a
// program against that header and runs it on this library against the daemon.
#include "internal.hpp"

namespace rsdiscovery::abi0 {

// Copies of the earlier declarations on purpose, not shared with the header (by a
// template or a macro): a definition both used would follow the next change to the
// header, and the programs built against this layout would break without a sign.

struct DeviceFilter {  // rsdiscovery::DeviceFilter before `host`
  std::optional<int> domain;
  std::vector<int> domains;
  std::string product_line;
  std::string source;
  std::string serial;
  std::string name;
  std::string address;
};

struct WatchOptions {  // rsdiscovery::WatchOptions before DeviceFilter had `host`
  bool initial = false;
  std::optional<std::uint64_t> last_event_id;
  DeviceFilter filter;
  bool reconnect = true;
  std::chrono::milliseconds max_reconnect_delay{2000};
  std::chrono::milliseconds idle_timeout{60000};
  std::chrono::milliseconds complete_timeout{10000};
  std::function<void(const WatchStatus&)> on_status;
};

// What the new layout adds is at the end of each, so the earlier members keep their
// offsets; a change to either new type that moves one must come with a compat of its own.
static_assert(sizeof(DeviceFilter) + sizeof(std::string) == sizeof(rsdiscovery::DeviceFilter));
static_assert(sizeof(WatchOptions) + sizeof(std::string) == sizeof(rsdiscovery::WatchOptions));

namespace {

rsdiscovery::DeviceFilter now(const DeviceFilter& f) {
  rsdiscovery::DeviceFilter out;
  out.domain = f.domain;
  out.domains = f.domains;
  out.product_line = f.product_line;
  out.source = f.source;
  out.serial = f.serial;
  out.name = f.name;
  out.address = f.address;
  return out;
}

rsdiscovery::WatchOptions now(WatchOptions&& o) {
  rsdiscovery::WatchOptions out;
  out.initial = o.initial;
  out.last_event_id = o.last_event_id;
  out.filter = now(o.filter);
  out.reconnect = o.reconnect;
  out.max_reconnect_delay = o.max_reconnect_delay;
  out.idle_timeout = o.idle_timeout;
  out.complete_timeout = o.complete_timeout;
  out.on_status = std::move(o.on_status);
  return out;
}

}  // namespace

// std::chrono::milliseconds is duration<int64_t>: long where that is 64 bits, else long long.
#if __SIZEOF_LONG__ == 8
#define RSD_ABI0_MS "NSt6chrono8durationIlSt5ratioILl1ELl1000EEEE"
#else
#define RSD_ABI0_MS "NSt6chrono8durationIxSt5ratioILx1ELx1000EEEE"
#endif

#define RSD_ABI0 __attribute__((visibility("default"), used))

RSD_ABI0 DeviceList list(Client& self, const DeviceFilter& filter) __asm__(
    "_ZN11rsdiscovery6Client4listERKNS_12DeviceFilterE");
DeviceList list(Client& self, const DeviceFilter& filter) { return self.list(now(filter)); }

RSD_ABI0 std::vector<Device> list_devices(Client& self, const DeviceFilter& filter) __asm__(
    "_ZN11rsdiscovery6Client12list_devicesERKNS_12DeviceFilterE");
std::vector<Device> list_devices(Client& self, const DeviceFilter& filter) {
  return self.list_devices(now(filter));
}

RSD_ABI0 std::optional<std::vector<Device>> wait_until(
    Client& self, const DeviceFilter& filter, const std::function<bool(const std::vector<Device>&)>& predicate,
    std::chrono::milliseconds timeout)
    __asm__("_ZN11rsdiscovery6Client10wait_untilERKNS_12DeviceFilterERKSt8functionIFbRKSt6vectorINS_6DeviceESaIS6_"
            "EEEE" RSD_ABI0_MS);
std::optional<std::vector<Device>> wait_until(Client& self, const DeviceFilter& filter,
                                              const std::function<bool(const std::vector<Device>&)>& predicate,
                                              std::chrono::milliseconds timeout) {
  return self.wait_until(now(filter), predicate, timeout);
}

// WatchOptions by value: not trivially copyable, so the caller passes the address of
// its copy and destroys it after the call, for a free function as for a member one.
RSD_ABI0 Watch watch(Client& self, WatchOptions options) __asm__(
    "_ZN11rsdiscovery6Client5watchENS_12WatchOptionsE");
Watch watch(Client& self, WatchOptions options) { return self.watch(now(std::move(options))); }

RSD_ABI0 DeviceView view(Client& self, WatchOptions options) __asm__(
    "_ZN11rsdiscovery6Client4viewENS_12WatchOptionsE");
DeviceView view(Client& self, WatchOptions options) { return self.view(now(std::move(options))); }

RSD_ABI0 Subscription subscribe(Client& self, std::function<void(const Event&)> on_event, WatchOptions options,
                                std::function<void(std::exception_ptr)> on_error,
                                std::function<void(const WatchStatus&)> on_status)
    __asm__("_ZN11rsdiscovery6Client5watchESt8functionIFvRKNS_5EventEEENS_12WatchOptionsES1_IFvNSt15__exception_"
            "ptr13exception_ptrEEES1_IFvRKNS_11WatchStatusEEE");
Subscription subscribe(Client& self, std::function<void(const Event&)> on_event, WatchOptions options,
                       std::function<void(std::exception_ptr)> on_error,
                       std::function<void(const WatchStatus&)> on_status) {
  return self.watch(std::move(on_event), now(std::move(options)), std::move(on_error), std::move(on_status));
}

}  // namespace rsdiscovery::abi0
