#include "rsd_model/device.hpp"

#include <cmath>
#include <cstdint>
#include <limits>

namespace rsd::model {

using nlohmann::json;

const char* to_string(Source source) {
  switch (source) {
    case Source::dds: return "dds";
    case Source::usb: return "usb";
  }
  return "unknown";
}

std::optional<Source> parse_source(std::string_view text) {
  if (text == "dds") return Source::dds;
  if (text == "usb") return Source::usb;
  return std::nullopt;
}

const char* to_string(DeviceState state) {
  switch (state) {
    case DeviceState::ok: return "ok";
    case DeviceState::warning: return "warning";
    case DeviceState::recovery: return "recovery";
  }
  return "unknown";
}

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

namespace {

// Each reader takes a value as the typed member holds it, or refuses it (the value
// then stays in `extra`, verbatim).
bool read(const json& v, std::string& out) {
  if (!v.is_string()) return false;
  out = v.get<std::string>();
  return true;
}
template <class T>
bool read(const json& v, std::optional<T>& out);  // defined after every plain reader
bool read(const json& v, bool& out) {
  if (!v.is_boolean()) return false;
  out = v.get<bool>();
  return true;
}
bool read(const json& v, int& out) {
  if (!v.is_number_integer()) return false;
  if (v.is_number_unsigned()) {
    const auto u = v.get<std::uint64_t>();
    if (u > static_cast<std::uint64_t>(std::numeric_limits<int>::max())) return false;
    out = static_cast<int>(u);
    return true;
  }
  const auto i = v.get<std::int64_t>();
  if (i < std::numeric_limits<int>::min() || i > std::numeric_limits<int>::max()) return false;
  out = static_cast<int>(i);
  return true;
}
bool read(const json& v, double& out) {
  if (!v.is_number()) return false;
  out = v.get<double>();
  return true;
}
bool read(const json& v, std::vector<std::string>& out) {
  if (!v.is_array()) return false;
  std::vector<std::string> values;
  for (const auto& e : v) {
    if (!e.is_string()) return false;
    values.push_back(e.get<std::string>());
  }
  out = std::move(values);
  return true;
}
bool read(const json& v, std::vector<Source>& out) {
  if (!v.is_array() || v.empty()) return false;  // empty is "not written"
  std::vector<Source> values;
  for (const auto& e : v) {
    auto s = e.is_string() ? parse_source(e.get_ref<const std::string&>()) : std::nullopt;
    if (!s) return false;
    values.push_back(*s);
  }
  out = std::move(values);
  return true;
}
bool read(const json& v, Source& out) {
  auto s = v.is_string() ? parse_source(v.get_ref<const std::string&>()) : std::nullopt;
  if (!s) return false;
  out = *s;
  return true;
}

// Objects the daemon owns are taken whole or not at all: an unknown key or a wrong
// type leaves the whole object verbatim in `extra`.
bool read(const json& v, Server& out) {
  if (!v.is_object()) return false;
  Server s;
  for (const auto& [key_text, value] : v.items()) {
    const std::string_view k = key_text;  // compared by length first
    bool ok = false;
    if (k == "participant-guid") ok = read(value, s.participant_guid);
    else if (k == "participant-name") ok = read(value, s.participant_name);
    else if (k == "addresses") ok = read(value, s.addresses);
    else if (k == "writer-guid") ok = read(value, s.writer_guid);
    if (!ok) return false;
  }
  out = std::move(s);
  return true;
}

bool read(const json& v, Usb& out) {
  if (!v.is_object()) return false;
  Usb u;
  int required = 0;
  for (const auto& [key_text, value] : v.items()) {
    const std::string_view k = key_text;  // compared by length first
    bool ok = false;
    if (k == "bus") ok = read(value, u.bus) && ++required;
    else if (k == "address") ok = read(value, u.address) && ++required;
    else if (k == "port-path") ok = read(value, u.port_path) && ++required;
    else if (k == "speed") ok = read(value, u.speed) && ++required;
    else if (k == "vid") ok = read(value, u.vid) && ++required;
    else if (k == "pid") ok = read(value, u.pid) && ++required;
    else if (k == "speed-mbps") ok = read(value, u.speed_mbps);
    else if (k == "usb-version") ok = read(value, u.usb_version);
    else if (k == "sysfs-path") ok = read(value, u.sysfs_path);
    if (!ok) return false;
  }
  if (required != 6) return false;
  out = std::move(u);
  return true;
}

template <class T>
bool read(const json& v, std::optional<T>& out) {
  T value{};
  if (!read(v, value)) return false;
  out = std::move(value);
  return true;
}

}  // namespace

json to_json(const Server& s) {
  json out = json::object();
  if (s.participant_guid) out["participant-guid"] = *s.participant_guid;
  if (s.participant_name) out["participant-name"] = *s.participant_name;
  if (s.addresses) out["addresses"] = *s.addresses;
  if (s.writer_guid) out["writer-guid"] = *s.writer_guid;
  return out;
}

namespace {

json usb_json(const Usb& u) {
  json out = {{"bus", u.bus},       {"address", u.address}, {"port-path", u.port_path},
              {"speed", u.speed},   {"vid", u.vid},         {"pid", u.pid}};
  if (u.speed_mbps) {
    // 5000, not 5000.0: what the kernel's sysfs says, and what a reader compares with.
    if (std::floor(*u.speed_mbps) == *u.speed_mbps && std::fabs(*u.speed_mbps) < 1e15)
      out["speed-mbps"] = static_cast<std::int64_t>(*u.speed_mbps);
    else
      out["speed-mbps"] = *u.speed_mbps;
  }
  if (u.usb_version) out["usb-version"] = *u.usb_version;
  if (u.sysfs_path) out["sysfs-path"] = *u.sysfs_path;
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
  if (d.server) out[key::server] = to_json(*d.server);
  if (d.usb) out[key::usb] = usb_json(*d.usb);
  if (!d.warnings.empty()) out[key::warnings] = d.warnings;
  put(key::merged_into, d.merged_into);
  return out;
}

Device device_from_json(const json& doc) {
  Device d;
  if (!doc.is_object()) return d;
  for (const auto& [key_text, v] : doc.items()) {
    // Compared as a string_view: by length first, which turns most of the 17 keys
    // away without a memcmp (a fifth of reading a device, callgrind).
    const std::string_view k = key_text;
    bool ok = false;
    if (k == key::id) ok = read(v, d.id) && !d.id.empty();
    else if (k == key::source) {
      Source s{};
      if ((ok = read(v, s))) d.source = s;
    } else if (k == key::sources) ok = read(v, d.sources);
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
    else if (k == key::server) ok = read(v, d.server);
    else if (k == key::usb) ok = read(v, d.usb);
    else if (k == key::warnings) ok = read(v, d.warnings) && !d.warnings.empty();
    else if (k == key::merged_into) ok = read(v, d.merged_into);
    if (!ok) {
      if (k == key::id) d.id.clear();
      if (k == key::warnings) d.warnings.clear();
      d.extra[k] = v;
    }
  }
  return d;
}

}  // namespace rsd::model
