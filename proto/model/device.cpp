// The device document: its one writer, and the daemon's reader (rsd_model/device.hpp).
#include "rsd_model/device.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

namespace rsd::model {

using nlohmann::json;

namespace {

// nlohmann's tree behind the few questions the readers below ask of a value.
class JsonView {
 public:
  explicit JsonView(const nlohmann::json& v) : v_(&v) {}
  bool is_object() const { return v_->is_object(); }
  bool is_array() const { return v_->is_array(); }
  bool is_string() const { return v_->is_string(); }
  bool is_bool() const { return v_->is_boolean(); }
  bool is_integer() const { return v_->is_number_integer(); }
  bool is_number() const { return v_->is_number(); }
  std::string_view text() const { return v_->get_ref<const std::string&>(); }
  bool boolean() const { return v_->get<bool>(); }
  bool integer(std::int64_t& out) const {
    if (v_->is_number_unsigned()) {
      const auto u = v_->get<std::uint64_t>();
      if (u > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) return false;
      out = static_cast<std::int64_t>(u);
      return true;
    }
    out = v_->get<std::int64_t>();
    return true;
  }
  double number() const { return v_->get<double>(); }
  std::size_t size() const { return v_->size(); }
  template <class F>
  bool each_element(F&& f) const {
    for (const auto& e : *v_)
      if (!f(JsonView(e))) return false;
    return true;
  }
  template <class F>
  bool each_member(F&& f) const {
    for (auto it = v_->begin(); it != v_->end(); ++it)
      if (!f(std::string_view(it.key()), JsonView(*it))) return false;
    return true;
  }
  nlohmann::json to_json() const { return *v_; }

 private:
  const nlohmann::json* v_;
};

namespace device_reader {

// Each reader takes a value as the typed member holds it, or refuses it (the value
// then stays in `extra`, verbatim). All declared first: they find one another by
// ordinary lookup.
bool read(const JsonView& v, std::string& out);
bool read(const JsonView& v, bool& out);
bool read(const JsonView& v, int& out);
bool read(const JsonView& v, double& out);
template <class T> bool read(const JsonView& v, std::vector<T>& out);
bool read(const JsonView& v, Source& out);
bool read(const JsonView& v, Server& out);
bool read(const JsonView& v, Usb& out);
bool read(const JsonView& v, Host& out);
bool read(const JsonView& v, InUse& out);
template <class T> bool read(const JsonView& v, std::optional<T>& out);

bool read(const JsonView& v, std::string& out) {
  if (!v.is_string()) return false;
  out = std::string(v.text());
  return true;
}
bool read(const JsonView& v, bool& out) {
  if (!v.is_bool()) return false;
  out = v.boolean();
  return true;
}
bool read(const JsonView& v, int& out) {
  std::int64_t i = 0;
  if (!v.is_integer() || !v.integer(i)) return false;
  if (i < std::numeric_limits<int>::min() || i > std::numeric_limits<int>::max()) return false;
  out = static_cast<int>(i);
  return true;
}
bool read(const JsonView& v, double& out) {
  if (!v.is_number()) return false;
  out = v.number();
  return true;
}
// An array whose every element the reader of T takes; any other leaves it in `extra`.
template <class T>
bool read(const JsonView& v, std::vector<T>& out) {
  if (!v.is_array()) return false;
  std::vector<T> values;
  values.reserve(v.size());
  if (!v.each_element([&](const JsonView& e) { return read(e, values.emplace_back()); })) return false;
  out = std::move(values);
  return true;
}
bool read(const JsonView& v, Source& out) {
  auto s = v.is_string() ? parse_source(v.text()) : std::nullopt;
  if (!s) return false;
  out = *s;
  return true;
}

// Objects the daemon owns are taken whole or not at all: an unknown key or a wrong
// type leaves the whole object verbatim in `extra`.
bool read(const JsonView& v, Server& out) {
  if (!v.is_object()) return false;
  Server s;
  // Keys compared as string_view: by length first.
  if (!v.each_member([&](std::string_view k, const JsonView& value) {
        if (k == part_key::participant_guid) return read(value, s.participant_guid);
        if (k == part_key::participant_name) return read(value, s.participant_name);
        if (k == part_key::addresses) return read(value, s.addresses);
        if (k == part_key::writer_guid) return read(value, s.writer_guid);
        return false;
      }))
    return false;
  out = std::move(s);
  return true;
}

bool read(const JsonView& v, Usb& out) {
  if (!v.is_object()) return false;
  Usb u;
  int required = 0;
  if (!v.each_member([&](std::string_view k, const JsonView& value) {
        if (k == part_key::bus) return read(value, u.bus) && ++required;
        if (k == part_key::address) return read(value, u.address) && ++required;
        if (k == part_key::port_path) return read(value, u.port_path) && ++required;
        if (k == part_key::speed) return read(value, u.speed) && ++required;
        if (k == part_key::vid) return read(value, u.vid) && ++required;
        if (k == part_key::pid) return read(value, u.pid) && ++required;
        if (k == part_key::speed_mbps) return read(value, u.speed_mbps);
        if (k == part_key::usb_version) return read(value, u.usb_version);
        if (k == part_key::sysfs_path) return read(value, u.sysfs_path);
        if (k == key::device_nodes) return read(value, u.device_nodes);
        return false;
      }))
    return false;
  if (required != 6) return false;
  out = std::move(u);
  return true;
}

bool read(const JsonView& v, Host& out) {
  if (!v.is_object()) return false;
  Host h;
  int required = 0;
  if (!v.each_member([&](std::string_view k, const JsonView& value) {
        if (k == part_key::name) return read(value, h.name) && ++required;
        if (k == part_key::addresses) return read(value, h.addresses) && ++required;
        if (k == part_key::participant_guid) return read(value, h.participant_guid);
        return false;
      }))
    return false;
  if (required != 2) return false;
  out = std::move(h);
  return true;
}

bool read(const JsonView& v, InUse& out) {
  if (!v.is_object()) return false;
  InUse u;
  int required = 0;
  if (!v.each_member([&](std::string_view k, const JsonView& value) {
        int n = -1;
        if (k == part_key::clients) return read(value, n) && n >= 0 && (u.clients = static_cast<std::size_t>(n), ++required);
        if (k == part_key::streaming) return read(value, u.streaming) && ++required;
        return false;
      }))
    return false;
  if (required != 2) return false;
  out = std::move(u);
  return true;
}

template <class T>
bool read(const JsonView& v, std::optional<T>& out) {
  T value{};
  if (!read(v, value)) return false;
  out = std::move(value);
  return true;
}

}  // namespace device_reader

Device read_device(const JsonView& doc) {
  using device_reader::read;
  Device d;
  if (!doc.is_object()) return d;
  doc.each_member([&](std::string_view k, const JsonView& v) {
    // Compared as a string_view: by length first, which turns most of the 19 keys
    // away without a memcmp (a fifth of reading a device, callgrind).
    bool ok = false;
    if (k == key::id) ok = read(v, d.id) && !d.id.empty();
    else if (k == key::source) {
      Source s{};
      if ((ok = read(v, s))) d.source = s;
    } else if (k == key::sources) ok = read(v, d.sources) && !d.sources.empty();  // empty: "not written"
    else if (k == key::domain) ok = read(v, d.domain);
    else if (k == key::topic_root) ok = read(v, d.topic_root);
    else if (k == key::name) ok = read(v, d.name);
    else if (k == key::serial) ok = read(v, d.serial);
    else if (k == key::product_line) ok = read(v, d.product_line);
    else if (k == key::product_id) ok = read(v, d.product_id);
    else if (k == key::fw_version) ok = read(v, d.fw_version);
    else if (k == key::recovery) ok = read(v, d.recovery);
    else if (k == key::first_seen) ok = read(v, d.first_seen);
    else if (k == key::last_seen) ok = read(v, d.last_seen);
    else if (k == key::unresponsive) ok = read(v, d.unresponsive);
    else if (k == key::ready) ok = read(v, d.ready);
    else if (k == key::ready_stage) ok = read(v, d.ready_stage);
    else if (k == key::server) ok = read(v, d.server);
    else if (k == key::usb) ok = read(v, d.usb);
    else if (k == key::host) ok = read(v, d.host);
    else if (k == key::warnings) ok = read(v, d.warnings) && !d.warnings.empty();
    else if (k == key::merged_into) ok = read(v, d.merged_into);
    else if (k == key::in_use) ok = read(v, d.in_use);
    if (!ok) {
      if (k == key::id) d.id.clear();
      if (k == key::sources) d.sources.clear();
      if (k == key::warnings) d.warnings.clear();
      d.extra[std::string(k)] = v.to_json();
    }
    return true;
  });
  return d;
}


}  // namespace

DeviceState Device::state() const {
  if (recovery.value_or(false)) return DeviceState::recovery;
  if (!warnings.empty()) return DeviceState::warning;
  return DeviceState::ok;
}

bool Device::seen_by(Source s) const {
  if (source == s) return true;
  for (auto x : sources)
    if (x == s) return true;
  return false;
}

bool Device::named_by(std::string_view k) const {
  if (k.empty()) return false;
  return (serial && *serial == k) || (topic_root && *topic_root == k);
}

json to_json(const Server& s) {
  json out = json::object();
  if (s.participant_guid) out[part_key::participant_guid] = *s.participant_guid;
  if (s.participant_name) out[part_key::participant_name] = *s.participant_name;
  if (s.addresses) out[part_key::addresses] = *s.addresses;
  if (s.writer_guid) out[part_key::writer_guid] = *s.writer_guid;
  return out;
}

json to_json(const Host& h) {
  json out = {{part_key::name, h.name}, {part_key::addresses, h.addresses}};
  if (h.participant_guid) out[part_key::participant_guid] = *h.participant_guid;
  return out;
}

json to_json(const InUse& u) { return {{part_key::clients, u.clients}, {part_key::streaming, u.streaming}}; }

namespace {

json usb_json(const Usb& u) {
  json out = {{part_key::bus, u.bus},       {part_key::address, u.address}, {part_key::port_path, u.port_path},
              {part_key::speed, u.speed},   {part_key::vid, u.vid},         {part_key::pid, u.pid}};
  if (u.speed_mbps) {
    // 5000, not 5000.0: what the kernel's sysfs says, and what a reader compares with.
    if (std::floor(*u.speed_mbps) == *u.speed_mbps && std::fabs(*u.speed_mbps) < 1e15)
      out[part_key::speed_mbps] = static_cast<std::int64_t>(*u.speed_mbps);
    else
      out[part_key::speed_mbps] = *u.speed_mbps;
  }
  if (u.usb_version) out[part_key::usb_version] = *u.usb_version;
  if (u.sysfs_path) out[part_key::sysfs_path] = *u.sysfs_path;
  if (!u.device_nodes.empty()) out[key::device_nodes] = u.device_nodes;
  return out;
}

}  // namespace

json to_json(const Device& d) {
  json out = d.extra.is_object() ? d.extra : json::object();
  auto put = [&](const char* k, const auto& v) {
    if (v) out[k] = *v;
  };
  if (!d.id.empty()) out[key::id] = d.id;
  if (d.source) out[key::source] = to_string(*d.source);
  if (!d.sources.empty()) {
    json list = json::array();
    for (auto s : d.sources) list.push_back(to_string(s));
    out[key::sources] = std::move(list);
  }
  put(key::domain, d.domain);
  put(key::topic_root, d.topic_root);
  put(key::name, d.name);
  put(key::serial, d.serial);
  put(key::product_line, d.product_line);
  put(key::product_id, d.product_id);
  put(key::fw_version, d.fw_version);
  put(key::recovery, d.recovery);
  put(key::first_seen, d.first_seen);
  put(key::last_seen, d.last_seen);
  put(key::unresponsive, d.unresponsive);
  put(key::ready, d.ready);
  put(key::ready_stage, d.ready_stage);
  if (d.server) out[key::server] = to_json(*d.server);
  if (d.usb) out[key::usb] = usb_json(*d.usb);
  if (d.host) out[key::host] = to_json(*d.host);
  if (!d.warnings.empty()) out[key::warnings] = d.warnings;
  put(key::merged_into, d.merged_into);
  if (d.in_use) out[key::in_use] = to_json(*d.in_use);
  return out;
}

Device device_from_json(const json& doc) { return read_device(JsonView(doc)); }

}  // namespace rsd::model
