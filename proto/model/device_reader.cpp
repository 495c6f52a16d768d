// The one reader of the device document (device.hpp's device_from_json): which keys
// exist, what type each takes and what goes to `extra` is decided here and nowhere else.
#include "rsd_model/device.hpp"

#include <cstdint>
#include <limits>
#include <string_view>
#include <utility>

namespace rsd::model {

using nlohmann::json;

namespace {

// Each reader takes a value as the typed member holds it, or refuses it (the value
// then stays in `extra`, verbatim). All declared first: the templates below find one
// another by ordinary lookup.
bool read(const json& v, std::string& out);
bool read(const json& v, bool& out);
bool read(const json& v, int& out);
bool read(const json& v, double& out);
template <class T> bool read(const json& v, std::vector<T>& out);
bool read(const json& v, Source& out);
bool read(const json& v, Server& out);
bool read(const json& v, Usb& out);
bool read(const json& v, Host& out);
bool read(const json& v, InUse& out);
template <class T> bool read(const json& v, std::optional<T>& out);

bool read(const json& v, std::string& out) {
  if (!v.is_string()) return false;
  out = v.get_ref<const std::string&>();
  return true;
}
bool read(const json& v, bool& out) {
  if (!v.is_boolean()) return false;
  out = v.get<bool>();
  return true;
}
bool read(const json& v, int& out) {
  if (v.is_number_unsigned()) {
    const auto u = v.get<std::uint64_t>();
    if (u > static_cast<std::uint64_t>(std::numeric_limits<int>::max())) return false;
    out = static_cast<int>(u);
    return true;
  }
  if (!v.is_number_integer()) return false;
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
// An array whose every element the reader of T takes; any other leaves it in `extra`.
template <class T>
bool read(const json& v, std::vector<T>& out) {
  if (!v.is_array()) return false;
  std::vector<T> values;
  values.reserve(v.size());
  for (const auto& e : v)
    if (!read(e, values.emplace_back())) return false;
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
// type leaves the whole object verbatim in `extra`. `f(key, value)` reads one member.
template <class F>
bool each_member(const json& v, F&& f) {
  if (!v.is_object()) return false;
  for (auto it = v.begin(); it != v.end(); ++it)
    if (!f(std::string_view(it.key()), *it)) return false;
  return true;
}

bool read(const json& v, Server& out) {
  Server s;
  // Keys compared as string_view: by length first.
  if (!each_member(v, [&](std::string_view k, const json& value) {
        if (k == "participant-guid") return read(value, s.participant_guid);
        if (k == "participant-name") return read(value, s.participant_name);
        if (k == "addresses") return read(value, s.addresses);
        if (k == "writer-guid") return read(value, s.writer_guid);
        return false;
      }))
    return false;
  out = std::move(s);
  return true;
}

bool read(const json& v, Usb& out) {
  Usb u;
  int required = 0;
  if (!each_member(v, [&](std::string_view k, const json& value) {
        if (k == "bus") return read(value, u.bus) && ++required;
        if (k == "address") return read(value, u.address) && ++required;
        if (k == "port-path") return read(value, u.port_path) && ++required;
        if (k == "speed") return read(value, u.speed) && ++required;
        if (k == "vid") return read(value, u.vid) && ++required;
        if (k == "pid") return read(value, u.pid) && ++required;
        if (k == "speed-mbps") return read(value, u.speed_mbps);
        if (k == "usb-version") return read(value, u.usb_version);
        if (k == "sysfs-path") return read(value, u.sysfs_path);
        return false;
      }))
    return false;
  if (required != 6) return false;
  out = std::move(u);
  return true;
}

bool read(const json& v, Host& out) {
  Host h;
  int required = 0;
  if (!each_member(v, [&](std::string_view k, const json& value) {
        if (k == "name") return read(value, h.name) && ++required;
        if (k == "addresses") return read(value, h.addresses) && ++required;
        if (k == "participant-guid") return read(value, h.participant_guid);
        return false;
      }))
    return false;
  if (required != 2) return false;
  out = std::move(h);
  return true;
}

bool read(const json& v, InUse& out) {
  InUse u;
  int required = 0;
  if (!each_member(v, [&](std::string_view k, const json& value) {
        int n = -1;
        if (k == "clients") return read(value, n) && n >= 0 && (u.clients = static_cast<std::size_t>(n), ++required);
        if (k == "streaming") return read(value, u.streaming) && ++required;
        return false;
      }))
    return false;
  if (required != 2) return false;
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

Device device_from_json(const json& doc) {
  Device d;
  each_member(doc, [&](std::string_view k, const json& v) {
    // Compared as a string_view: by length first, which turns most of the keys away
    // without a memcmp.
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
      d.extra[std::string(k)] = v;
    }
    return true;
  });
  return d;
}

}  // namespace rsd::model
