// The daemon's JSON documents as the public types, and the small pure helpers.
#include "internal.hpp"

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

// Text of a string member; numbers are written out (a serial sent as a number is
// still a serial); anything else or absent gives "".
std::string text(const json& doc, const char* key) {
  auto it = doc.find(key);
  if (it == doc.end()) return {};
  if (it->is_string()) return it->get<std::string>();
  if (it->is_number()) return it->dump();
  return {};
}

std::uint64_t count(const json& doc, const char* key) {
  auto it = doc.find(key);
  if (it != doc.end() && it->is_number_unsigned()) return it->get<std::uint64_t>();
  if (it != doc.end() && it->is_number_integer() && it->get<std::int64_t>() >= 0)
    return static_cast<std::uint64_t>(it->get<std::int64_t>());
  return 0;
}

std::optional<int> integer(const json& doc, const char* key) {
  auto it = doc.find(key);
  if (it != doc.end() && it->is_number_integer()) {
    auto v = it->get<std::int64_t>();
    if (v >= INT32_MIN && v <= INT32_MAX) return static_cast<int>(v);
  }
  return std::nullopt;
}

std::vector<std::string> strings(const json& doc, const char* key) {
  std::vector<std::string> out;
  auto it = doc.find(key);
  if (it == doc.end() || !it->is_array()) return out;
  for (const auto& v : *it)
    if (v.is_string()) out.push_back(v.get<std::string>());
  return out;
}

}  // namespace

Device device_from_json(const json& doc) {
  if (!doc.is_object()) malformed("a device is not a JSON object");
  auto id = doc.find("id");
  if (id == doc.end() || !id->is_string() || id->get_ref<const std::string&>().empty())
    malformed("a device has no \"id\"");
  Device d;
  d.id = id->get<std::string>();
  d.source = text(doc, "source");
  d.sources = strings(doc, "sources");
  if (d.sources.empty() && !d.source.empty()) d.sources.push_back(d.source);
  if (d.source.empty() && !d.sources.empty()) d.source = d.sources.front();
  d.domain = integer(doc, "domain");
  d.topic_root = text(doc, "topic-root");
  d.name = text(doc, "name");
  d.serial = text(doc, "serial");
  d.product_line = text(doc, "product-line");
  d.product_id = text(doc, "product-id");
  d.fw_version = text(doc, "fw-version");
  if (auto r = doc.find("recovery"); r != doc.end() && r->is_boolean()) d.recovery = r->get<bool>();
  d.first_seen = text(doc, "first-seen");
  d.last_seen = text(doc, "last-seen");
  if (auto s = doc.find("server"); s != doc.end() && s->is_object()) {
    ServerInfo info;
    info.participant_guid = text(*s, "participant-guid");
    info.participant_name = text(*s, "participant-name");
    info.addresses = strings(*s, "addresses");
    d.server = std::move(info);
  }
  if (auto u = doc.find("usb"); u != doc.end() && u->is_object()) {
    UsbInfo info;
    info.bus = integer(*u, "bus");
    info.port_path = text(*u, "port-path");
    info.speed = text(*u, "speed");
    d.usb = std::move(info);
  }
  if (auto w = doc.find("warning"); w != doc.end() && !w->is_null())
    d.warning = w->is_string() ? w->get<std::string>() : w->dump();
  d.json = doc.dump();
  return d;
}

DomainStatus domain_from_json(const json& doc) {
  if (!doc.is_object()) malformed("a domain entry is not a JSON object");
  auto domain = integer(doc, "domain");
  if (!domain) malformed("a domain entry has no \"domain\" number");
  DomainStatus s;
  s.domain = *domain;
  s.state = text(doc, "state");
  s.participant_guid = text(doc, "participant-guid");
  s.devices = count(doc, "devices");
  s.accepted = count(doc, "accepted");
  if (auto r = doc.find("rejected"); r != doc.end() && r->is_object())
    for (const auto& [reason, n] : r->items())
      if (n.is_number_integer() || n.is_number_unsigned()) s.rejected[reason] = count(*r, reason.c_str());
  s.complete = reports_complete(doc);
  s.json = doc.dump();
  return s;
}

Health health_from_json(const json& doc) {
  if (!doc.is_object() || !doc.contains("status")) malformed("/healthz has no \"status\"");
  Health h;
  h.status = text(doc, "status");
  h.version = text(doc, "version");
  h.devices = count(doc, "devices");
  h.complete = reports_complete(doc);
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
  if (!filter.product_line.empty()) add("product-line", filter.product_line);
  if (!filter.source.empty()) add("source", filter.source);
  return path;
}

}  // namespace detail

std::string Device::field(const std::string& key) const {
  auto doc = nlohmann::json::parse(json, nullptr, false);
  if (!doc.is_object()) return {};
  auto it = doc.find(key);
  return it == doc.end() ? std::string() : it->dump();
}

Device parse_device(const std::string& json_text) {
  auto doc = nlohmann::json::parse(json_text, nullptr, false);
  if (doc.is_discarded()) throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd: not JSON");
  return detail::device_from_json(doc);
}

bool DeviceFilter::matches(const Device& device) const {
  if (domain && device.domain != domain) return false;
  if (!product_line.empty() && device.product_line != product_line) return false;
  if (!source.empty()) {
    bool any = device.source == source;
    for (const auto& s : device.sources) any = any || s == source;
    if (!any) return false;
  }
  return true;
}

}  // namespace rsdiscovery
