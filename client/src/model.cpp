// The daemon's JSON documents as the public types, and the small pure helpers.
#include "internal.hpp"

#include "rsd_model/description.hpp"
#include "rsd_model/participant.hpp"
#include "rsd_model/status.hpp"

namespace rsdiscovery {

const char* version() { return RSDISCOVERY_VERSION; }

const char* to_string(ErrorCode code) {
  switch (code) {
    case ErrorCode::not_running: return "not_running";
    case ErrorCode::permission_denied: return "permission_denied";
    case ErrorCode::not_found: return "not_found";
    case ErrorCode::timeout: return "timeout";
    case ErrorCode::malformed_reply: return "malformed_reply";
    case ErrorCode::version_mismatch: return "version_mismatch";
    case ErrorCode::http_error: return "http_error";
    case ErrorCode::bad_endpoint: return "bad_endpoint";
    case ErrorCode::cancelled: return "cancelled";
  }
  return "unknown";
}

const char* to_string(Event::Type type) {
  switch (type) {
    case Event::Type::added: return "added";
    case Event::Type::changed: return "changed";
    case Event::Type::removed: return "removed";
  }
  return "unknown";
}

namespace detail {
namespace {

using nlohmann::json;

[[noreturn]] void malformed(const std::string& what) {
  throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd: " + what);
}

// A document read through the shared model (rsd_model): its MalformedDocument
// becomes the library's Error(malformed_reply), for every document alike.
template <class Read>
auto read_model(Read read, const json& doc) -> decltype(read(doc)) {
  try {
    return read(doc);
  } catch (const rsd::model::MalformedDocument& e) {
    malformed(e.what());
  }
}

}  // namespace

// The daemon's model (proto/model) reads the document; this only maps it onto the
// public struct, which has to stay free of nlohmann.
Device device_from_json(const json& doc) {
  if (!doc.is_object()) malformed("a device is not a JSON object");
  const rsd::model::Device m = rsd::model::device_from_json(doc);
  if (m.id.empty()) malformed("a device has no \"id\"");
  Device d;
  d.id = m.id;
  for (auto s : m.sources) d.sources.push_back(rsd::model::to_string(s));
  if (m.source) d.source = rsd::model::to_string(*m.source);
  if (d.sources.empty() && !d.source.empty()) d.sources.push_back(d.source);
  if (d.source.empty() && !d.sources.empty()) d.source = d.sources.front();
  d.domain = m.domain;
  d.topic_root = m.topic_root.value_or("");
  d.name = m.name.value_or("");
  d.serial = m.serial.value_or("");
  d.product_line = m.product_line.value_or("");
  d.product_id = m.product_id.value_or("");
  d.fw_version = m.fw_version.value_or("");
  d.recovery = m.recovery.value_or(false);
  d.first_seen = m.first_seen.value_or("");
  d.last_seen = m.last_seen.value_or("");
  if (m.server) {
    ServerInfo info;
    info.participant_guid = m.server->participant_guid.value_or("");
    info.participant_name = m.server->participant_name.value_or("");
    info.addresses = m.server->addresses.value_or(std::vector<std::string>{});
    d.server = std::move(info);
  }
  if (m.usb) {
    UsbInfo info;
    info.bus = m.usb->bus;
    info.port_path = m.usb->port_path;
    info.speed = m.usb->speed;
    d.usb = std::move(info);
  }
  d.warnings = m.warnings;
  if (!d.warnings.empty()) d.warning = d.warnings.front();
  d.state = rsd::model::to_string(m.state());
  d.json = doc.dump();
  return d;
}

// The model (proto/model/rsd_model/status.hpp) reads the status documents, with the
// daemon's own spelling and checks; these map them onto the public types.
namespace {

StreamProfile public_profile(const rsd::model::Profile& p) {
  return {p.fps, p.format.value_or(""), p.width.value_or(0), p.height.value_or(0)};
}

std::vector<CameraOption> public_options(const std::vector<rsd::model::Option>& options) {
  std::vector<CameraOption> out;
  for (const auto& o : options)
    out.push_back({o.name, o.value.is_null() ? std::string() : o.value.dump(), o.description.value_or(""),
                   o.json.dump()});
  return out;
}

}  // namespace

Description description_from_json(const json& doc) {
  auto m = read_model(rsd::model::description_from_json, doc);
  Description d;
  for (const auto& s : m.streams) {
    CameraStream st;
    st.name = s.name;
    st.type = s.type;
    st.sensor = s.sensor_name;
    for (const auto& p : s.profiles) st.profiles.push_back(public_profile(p));
    if (s.default_profile) st.default_profile = public_profile(*s.default_profile);
    st.metadata = s.metadata_enabled;
    st.options = public_options(s.options);
    d.streams.push_back(std::move(st));
  }
  d.device_options = public_options(m.device_options);
  d.json = doc.dump();
  return d;
}

DomainStatus domain_from_json(const json& doc) {
  auto m = read_model(rsd::model::domain_status_from_json, doc);
  DomainStatus s;
  s.domain = m.domain;
  s.state = std::string(rsd::model::to_string(m.state));
  s.participant_guid = m.participant_guid;
  s.devices = m.devices;
  s.accepted = m.accepted;
  s.rejected = m.rejected;
  s.complete = m.complete;
  s.json = doc.dump();
  return s;
}

Participant participant_from_json(const json& doc) {
  auto m = read_model(rsd::model::participant_from_json, doc);
  Participant p;
  p.domain = m.domain;
  p.guid = std::move(m.guid);
  p.name = std::move(m.name);
  p.vendor = std::string(rsd::model::to_string(m.vendor));
  p.addresses = std::move(m.addresses);
  p.host = m.host.value_or("");
  p.process = m.process.value_or("");
  p.lease_seconds = m.lease_seconds;
  p.state = std::string(rsd::model::to_string(m.state));
  p.first_seen = std::move(m.first_seen);
  p.last_seen = std::move(m.last_seen);
  p.device_info_writers = m.device_info_writers;
  p.devices = m.devices;
  p.never_announced = m.never_announced;
  p.topic_roots = std::move(m.topic_roots);
  p.endpoints = m.endpoints;
  p.json = doc.dump();
  return p;
}

Health health_from_json(const json& doc) {
  auto m = read_model(rsd::model::health_from_json, doc);
  Health h;
  h.status = m.status;
  h.version = m.version;
  h.devices = m.devices;
  h.complete = m.complete;
  h.json = doc.dump();
  return h;
}

bool same_device(const json& a, const json& b) {
  if (!a.is_object() || !b.is_object()) return a == b;
  if (a.size() != b.size()) return false;
  for (auto it = a.begin(); it != a.end(); ++it) {
    if (it.key() == "last-seen" || it.key() == "first-seen") continue;
    auto other = b.find(it.key());
    if (other == b.end() || *other != it.value()) return false;
  }
  return true;
}

bool reports_complete(const json& doc) {
  auto it = doc.find("complete");
  return it == doc.end() || !it->is_boolean() || it->get<bool>();
}

std::string percent_encode(std::string_view text) {
  static const char* hex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : text) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

std::string devices_path(const DeviceFilter& filter) {
  std::string path = "/v1/devices";
  char sep = '?';
  auto add = [&](const char* key, const std::string& value) {
    path += sep;
    path += key;
    path += '=';
    path += percent_encode(value);
    sep = '&';
  };
  if (filter.domain) add("domain", std::to_string(*filter.domain));
  for (int d : filter.domains) add("domain", std::to_string(d));
  if (!filter.product_line.empty()) add("product-line", filter.product_line);
  if (!filter.source.empty()) add("source", filter.source);
  if (!filter.serial.empty()) add("serial", filter.serial);
  if (!filter.name.empty()) add("name", filter.name);
  if (!filter.address.empty()) add("address", filter.address);
  return path;
}

}  // namespace detail

std::string Device::field(const std::string& key) const {
  auto doc = nlohmann::json::parse(json, nullptr, false);
  if (!doc.is_object()) return {};
  auto it = doc.find(key);
  return it == doc.end() ? std::string() : it->dump();
}

Description parse_description(const std::string& json_text) {
  auto doc = nlohmann::json::parse(json_text, nullptr, false);
  if (doc.is_discarded()) throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd: not JSON");
  return detail::description_from_json(doc);
}

Device parse_device(const std::string& json_text) {
  auto doc = nlohmann::json::parse(json_text, nullptr, false);
  if (doc.is_discarded()) throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd: not JSON");
  return detail::device_from_json(doc);
}

}  // namespace rsdiscovery
