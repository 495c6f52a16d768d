// The one reader of the device document (device.hpp's device_from_json), written once
// over a small view of a parsed JSON value, so that it reads any parser's tree the
// same way: nlohmann's (the daemon; most of the client) and RapidJSON's (the client's
// device list, which a cold `rs-discover list` spent most of its time parsing with
// nlohmann: bench/). Which keys exist, what type each takes and what goes to `extra`
// is decided here and nowhere else.
//
// A view V is a cheap copyable handle on one value with:
//   is_object() is_array() is_string() is_bool() is_integer() is_number()
//   text() -> std::string_view         (is_string)
//   boolean() -> bool                  (is_bool)
//   integer(std::int64_t&) -> bool     false when it does not fit (is_integer)
//   number() -> double                 (is_number)
//   size() -> std::size_t              (is_array)
//   each_element(f), each_member(f)    f(V) / f(std::string_view key, V) returning
//                                      false stops, and each_* then returns false
//   to_json() -> nlohmann::json        the value as it is, for `extra`
#pragma once

#include "rsd_model/device.hpp"

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace rsd::model {

// nlohmann's tree as a view (what device_from_json reads).
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
// then stays in `extra`, verbatim). All declared first: the templates below find
// one another by ordinary lookup.
template <class V> bool read(const V& v, std::string& out);
template <class V> bool read(const V& v, bool& out);
template <class V> bool read(const V& v, int& out);
template <class V> bool read(const V& v, double& out);
template <class V, class T> bool read(const V& v, std::vector<T>& out);
template <class V> bool read(const V& v, Source& out);
template <class V> bool read(const V& v, Server& out);
template <class V> bool read(const V& v, Usb& out);
template <class V> bool read(const V& v, Host& out);
template <class V> bool read(const V& v, InUse& out);
template <class V, class T> bool read(const V& v, std::optional<T>& out);

template <class V>
bool read(const V& v, std::string& out) {
  if (!v.is_string()) return false;
  out = std::string(v.text());
  return true;
}
template <class V>
bool read(const V& v, bool& out) {
  if (!v.is_bool()) return false;
  out = v.boolean();
  return true;
}
template <class V>
bool read(const V& v, int& out) {
  std::int64_t i = 0;
  if (!v.is_integer() || !v.integer(i)) return false;
  if (i < std::numeric_limits<int>::min() || i > std::numeric_limits<int>::max()) return false;
  out = static_cast<int>(i);
  return true;
}
template <class V>
bool read(const V& v, double& out) {
  if (!v.is_number()) return false;
  out = v.number();
  return true;
}
// An array whose every element the reader of T takes; any other leaves it in `extra`.
template <class V, class T>
bool read(const V& v, std::vector<T>& out) {
  if (!v.is_array()) return false;
  std::vector<T> values;
  values.reserve(v.size());
  if (!v.each_element([&](const V& e) { return read(e, values.emplace_back()); })) return false;
  out = std::move(values);
  return true;
}
template <class V>
bool read(const V& v, Source& out) {
  auto s = v.is_string() ? parse_source(v.text()) : std::nullopt;
  if (!s) return false;
  out = *s;
  return true;
}

// Objects the daemon owns are taken whole or not at all: an unknown key or a wrong
// type leaves the whole object verbatim in `extra`.
template <class V>
bool read(const V& v, Server& out) {
  if (!v.is_object()) return false;
  Server s;
  // Keys compared as string_view: by length first.
  if (!v.each_member([&](std::string_view k, const V& value) {
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

template <class V>
bool read(const V& v, Usb& out) {
  if (!v.is_object()) return false;
  Usb u;
  int required = 0;
  if (!v.each_member([&](std::string_view k, const V& value) {
        if (k == "bus") return read(value, u.bus) && ++required;
        if (k == "address") return read(value, u.address) && ++required;
        if (k == "port-path") return read(value, u.port_path) && ++required;
        if (k == "speed") return read(value, u.speed) && ++required;
        if (k == "vid") return read(value, u.vid) && ++required;
        if (k == "pid") return read(value, u.pid) && ++required;
        if (k == "speed-mbps") return read(value, u.speed_mbps);
        if (k == "usb-version") return read(value, u.usb_version);
        if (k == "sysfs-path") return read(value, u.sysfs_path);
        if (k == key::device_nodes) return read(value, u.device_nodes);
        return false;
      }))
    return false;
  if (required != 6) return false;
  out = std::move(u);
  return true;
}

template <class V>
bool read(const V& v, Host& out) {
  if (!v.is_object()) return false;
  Host h;
  int required = 0;
  if (!v.each_member([&](std::string_view k, const V& value) {
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

template <class V>
bool read(const V& v, InUse& out) {
  if (!v.is_object()) return false;
  InUse u;
  int required = 0;
  if (!v.each_member([&](std::string_view k, const V& value) {
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

template <class V, class T>
bool read(const V& v, std::optional<T>& out) {
  T value{};
  if (!read(v, value)) return false;
  out = std::move(value);
  return true;
}

}  // namespace device_reader

// The device document read from any view (see the top of this file); never throws.
template <class V>
Device read_device(const V& doc) {
  using device_reader::read;
  Device d;
  if (!doc.is_object()) return d;
  doc.each_member([&](std::string_view k, const V& v) {
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

}  // namespace rsd::model
