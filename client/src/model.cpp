// The daemon's JSON documents as the public types, and the small pure helpers.
#include "internal.hpp"

#include <cstring>

#include "rsd_model/clients.hpp"
#include "rsd_model/description.hpp"
#include "rsd_model/expected.hpp"
#include "rsd_model/participant.hpp"
#include "rsd_model/removal.hpp"
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

Device device_from_json(const json& doc, std::string text) {
  if (!doc.is_object()) malformed("a device is not a JSON object");
  return device_from_model(rsd::model::device_from_json(doc), text.empty() ? doc.dump() : std::move(text));
}

// The daemon's model (proto/model) reads the document; this only maps it onto the
// public struct, which has to stay free of nlohmann.
Device device_from_model(rsd::model::Device m, std::string text) {
  if (m.id.empty()) malformed("a device has no \"id\"");
  // Moved, not copied: the model is a step on the way (a cold list of 100 devices
  // spent a tenth of its instructions copying strings across).
  Device d;
  d.id = std::move(m.id);
  for (auto s : m.sources) d.sources.push_back(rsd::model::to_string(s));
  if (m.source) d.source = rsd::model::to_string(*m.source);
  if (d.sources.empty() && !d.source.empty()) d.sources.push_back(d.source);
  if (d.source.empty() && !d.sources.empty()) d.source = d.sources.front();
  d.domain = m.domain;
  const auto take = [](std::optional<std::string>& v) { return v ? std::move(*v) : std::string(); };
  d.topic_root = take(m.topic_root);
  d.name = take(m.name);
  d.serial = take(m.serial);
  d.product_line = take(m.product_line);
  d.product_id = take(m.product_id);
  d.fw_version = take(m.fw_version);
  d.recovery = m.recovery.value_or(false);
  d.first_seen = take(m.first_seen);
  d.last_seen = take(m.last_seen);
  if (m.server) {
    ServerInfo info;
    info.participant_guid = take(m.server->participant_guid);
    info.participant_name = take(m.server->participant_name);
    if (m.server->addresses) info.addresses = std::move(*m.server->addresses);
    d.server = std::move(info);
  }
  if (m.usb) {
    UsbInfo info;
    info.bus = m.usb->bus;
    info.port_path = std::move(m.usb->port_path);
    info.speed = std::move(m.usb->speed);
    d.usb = std::move(info);
  }
  d.state = rsd::model::to_string(m.state());
  d.warnings = std::move(m.warnings);
  if (!d.warnings.empty()) d.warning = d.warnings.front();
  d.json = std::move(text);
  return d;
}

namespace {

// Skips the JSON value starting at text[i] (after whitespace), returning the index
// just past it. Valid JSON only (the caller parsed it first): it tracks strings and
// nesting, nothing else.
std::size_t skip_value(std::string_view text, std::size_t i) {
  int depth = 0;
  for (; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"') {  // to the closing quote: one not escaped by an odd run of backslashes
      for (;;) {
        const void* q = std::memchr(text.data() + i + 1, '"', text.size() - i - 1);
        if (!q) return text.size();
        i = static_cast<std::size_t>(static_cast<const char*>(q) - text.data());
        std::size_t slashes = 0;
        while (text[i - 1 - slashes] == '\\') ++slashes;
        if (slashes % 2 == 0) break;
      }
      if (depth == 0) return i + 1;
    } else if (c == '{' || c == '[') {
      ++depth;
    } else if (c == '}' || c == ']') {
      if (depth == 0) return i;  // the end of the enclosing container: a scalar ended here
      if (--depth == 0) return i + 1;
    } else if (depth == 0 && (c == ',' || c == ' ' || c == '\n' || c == '\r' || c == '\t')) {
      return i;
    }
  }
  return i;
}

std::size_t skip_space(std::string_view text, std::size_t i) {
  while (i < text.size() && (text[i] == ' ' || text[i] == '\n' || text[i] == '\r' || text[i] == '\t')) ++i;
  return i;
}

}  // namespace

// Why by hand: writing each device back out of the parsed tree (dump) was a large
// part of a cold `rs-discover list` (callgrind). nlohmann 3.11 does not say where a
// value lies in its input.
std::vector<std::string_view> array_member_elements(std::string_view text, std::string_view key) {
  std::vector<std::string_view> out;
  std::size_t i = skip_space(text, 0);
  if (i >= text.size() || text[i] != '{') return out;
  i = skip_space(text, i + 1);
  while (i < text.size() && text[i] == '"') {
    const std::size_t name_end = skip_value(text, i);
    const bool wanted = text.substr(i + 1, name_end - i - 2) == key;  // the daemon's keys carry no escapes
    i = skip_space(text, skip_space(text, name_end) + 1);  // past ':'
    if (!wanted) {
      i = skip_space(text, skip_value(text, i));
      if (i < text.size() && text[i] == ',') i = skip_space(text, i + 1);
      continue;
    }
    if (i >= text.size() || text[i] != '[') return out;
    i = skip_space(text, i + 1);
    while (i < text.size() && text[i] != ']') {
      const std::size_t end = skip_value(text, i);
      if (end == i) return {};  // not JSON after all (a stray '}' or ','): no slices
      out.push_back(text.substr(i, end - i));
      i = skip_space(text, end);
      if (i < text.size() && text[i] == ',') i = skip_space(text, i + 1);
    }
    return out;
  }
  return out;
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

CameraClients clients_from_json(const json& doc) {
  auto m = read_model(rsd::model::device_clients_from_json, doc);
  CameraClients out;
  for (auto& c : m.clients)
    out.clients.push_back({std::move(c.guid), std::move(c.name), std::string(rsd::model::to_string(c.vendor)),
                           std::move(c.addresses), c.host.value_or(""), c.process.value_or(""), std::move(c.since),
                           std::move(c.streams), std::move(c.ros_nodes)});
  for (const auto& [name, readers] : m.streams) out.streams[name] = readers;
  out.json = doc.dump();
  return out;
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

Expected expected_from_json(const json& doc) {
  auto m = read_model(rsd::model::expected_report_from_json, doc);
  const auto public_list = [](const std::vector<rsd::model::ExpectedStatus>& list) {
    std::vector<ExpectedCamera> out;
    for (const auto& s : list)
      out.push_back({s.camera.name, s.camera.serial, s.camera.topic_root, s.id.value_or(""), s.last_seen.value_or(""),
                     s.reason.value_or("")});
    return out;
  };
  Expected e;
  e.complete = m.complete;
  e.present = public_list(m.present);
  e.missing = public_list(m.missing);
  e.json = doc.dump();
  return e;
}

bool same_device(const json& a, const json& b) {
  if (!a.is_object() || !b.is_object()) return a == b;
  // Not the camera's: the times move on every announcement, and an event's reason or
  // arrival rides on the document it carries, not on the one a list gives.
  const auto ignored = [](const std::string& k) {
    return k == rsd::model::key::last_seen || k == rsd::model::key::first_seen || k == rsd::model::key::reason ||
           k == rsd::model::key::arrival || k == rsd::model::key::away_since;
  };
  const auto covered = [&](const json& x, const json& y) {
    for (auto it = x.begin(); it != x.end(); ++it) {
      if (ignored(it.key())) continue;
      auto other = y.find(it.key());
      if (other == y.end() || *other != it.value()) return false;
    }
    return true;
  };
  return covered(a, b) && covered(b, a);
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
  for (int d : filter.domains()) add("domain", std::to_string(d));
  if (!filter.product_line().empty()) add("product-line", filter.product_line());
  if (!filter.source().empty()) add("source", filter.source());
  if (!filter.serial().empty()) add("serial", filter.serial());
  if (!filter.name().empty()) add("name", filter.name());
  if (!filter.address().empty()) add("address", filter.address());
  if (!filter.host().empty()) add("host", filter.host());
  if (const auto used = filter.in_use()) add("in-use", *used ? "true" : "false");
  return path;
}

std::string with_fields(std::string path, const std::vector<std::string>& fields) {
  std::string list;
  for (const auto& f : fields) list += (list.empty() ? "" : ",") + f;
  path += path.find('?') == std::string::npos ? "?fields=" : "&fields=";
  return path + percent_encode(list);
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

std::optional<SharingHost> sharing_host(const Device& device) {
  if (device.source != "remote-usb") return std::nullopt;
  SharingHost out;
  const auto doc = nlohmann::json::parse(device.json, nullptr, false);
  if (!doc.is_object()) return out;
  auto host = rsd::model::device_from_json(doc).host;
  if (!host) return out;
  out.name = std::move(host->name);
  out.addresses = std::move(host->addresses);
  out.participant_guid = host->participant_guid.value_or("");
  return out;
}

std::optional<DeviceInUse> in_use_of(const Device& device) {
  const auto doc = nlohmann::json::parse(device.json, nullptr, false);
  if (!doc.is_object() || !doc.contains("in-use")) return std::nullopt;
  auto in_use = rsd::model::device_from_json(doc).in_use;
  if (!in_use) return std::nullopt;
  return DeviceInUse{in_use->clients, std::move(in_use->streaming)};
}

Device parse_device(const std::string& json_text) {
  auto doc = nlohmann::json::parse(json_text, nullptr, false);
  if (doc.is_discarded()) throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd: not JSON");
  return detail::device_from_json(doc, json_text);
}

}  // namespace rsdiscovery
