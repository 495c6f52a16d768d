#include "rsd_model/device.hpp"
#include "rsd_model/device_reader.hpp"

#include <cmath>
#include <cstdint>

namespace rsd::model {

using nlohmann::json;

const char* to_string(Source source) {
  switch (source) {
    case Source::dds: return "dds";
    case Source::usb: return "usb";
    case Source::remote_usb: return "remote-usb";
  }
  return "unknown";
}

std::optional<Source> parse_source(std::string_view text) {
  if (text == "dds") return Source::dds;
  if (text == "usb") return Source::usb;
  if (text == "remote-usb") return Source::remote_usb;
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

json to_json(const Server& s) {
  json out = json::object();
  if (s.participant_guid) out["participant-guid"] = *s.participant_guid;
  if (s.participant_name) out["participant-name"] = *s.participant_name;
  if (s.addresses) out["addresses"] = *s.addresses;
  if (s.writer_guid) out["writer-guid"] = *s.writer_guid;
  return out;
}

json to_json(const Host& h) {
  json out = {{"name", h.name}, {"addresses", h.addresses}};
  if (h.participant_guid) out["participant-guid"] = *h.participant_guid;
  return out;
}

json to_json(const InUse& u) { return {{"clients", u.clients}, {"streaming", u.streaming}}; }

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
