// A device document and GET /v1/devices' reply read into the public types, with
// RapidJSON (json.hpp). The rules are the daemon's reader's (proto/model device.cpp),
// for what the public Device holds: a value of another type than the key's is not
// taken, and an object the daemon owns ("server", "usb", "host", "in-use") is taken
// whole or not at all. tests/unit holds the two readers to the same answers.
#include "internal.hpp"

#include "rsd_model/spelling.hpp"

#include <cstdint>
#include <cstring>
#include <limits>

namespace rsdiscovery::detail {

namespace {

namespace key = rsd::model::key;
namespace part_key = rsd::model::part_key;
using json::Value;

[[noreturn]] void malformed(const std::string& what) {
  throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd: " + what);
}

std::string_view name_of(const Value::ConstMemberIterator& m) {
  return {m->name.GetString(), m->name.GetStringLength()};
}

// Each reader takes a value as the field holds it, or refuses it.
bool take(const Value& v, std::string& out) {
  if (!v.IsString()) return false;
  out.assign(v.GetString(), v.GetStringLength());
  return true;
}
bool take(const Value& v, int& out) {
  auto i = json::integer(&v);
  if (!i || *i < std::numeric_limits<int>::min() || *i > std::numeric_limits<int>::max()) return false;
  out = static_cast<int>(*i);
  return true;
}
bool take_strings(const Value& v, std::vector<std::string>& out) {
  if (!v.IsArray()) return false;
  for (const auto& e : v.GetArray())
    if (!e.IsString()) return false;
  out = json::texts(&v);
  return true;
}
bool take_source(const Value& v, std::string& out) {
  auto t = json::text(&v);
  if (!t || !rsd::model::parse_source(*t)) return false;
  out = std::string(*t);
  return true;
}
// Every member of an object through `each` (false: refused); the object is refused
// when any member is, or when fewer than `required` members counted themselves.
template <class Each>
bool whole(const Value& v, int required, Each each) {
  if (!v.IsObject()) return false;
  int counted = 0;
  for (auto m = v.MemberBegin(); m != v.MemberEnd(); ++m) {
    const int took = each(name_of(m), m->value);
    if (took < 0) return false;
    counted += took;
  }
  return counted == required;
}
// each() answers: -1 refused, 0 taken (optional), 1 taken (required).
int took(bool ok, bool required = false) { return ok ? (required ? 1 : 0) : -1; }

bool take(const Value& v, ServerInfo& out) {
  ServerInfo s;
  std::string writer;
  const bool ok = whole(v, 0, [&](std::string_view k, const Value& value) {
    if (k == part_key::participant_guid) return took(take(value, s.participant_guid));
    if (k == part_key::participant_name) return took(take(value, s.participant_name));
    if (k == part_key::addresses) return took(take_strings(value, s.addresses));
    if (k == part_key::writer_guid) return took(take(value, writer));
    return -1;
  });
  if (ok) out = std::move(s);
  return ok;
}

bool take(const Value& v, UsbInfo& out) {
  UsbInfo u;
  int bus = 0, address = 0;
  std::string text;
  std::vector<std::string> nodes;
  const bool ok = whole(v, 6, [&](std::string_view k, const Value& value) {
    if (k == part_key::bus) return took(take(value, bus), true);
    if (k == part_key::address) return took(take(value, address), true);
    if (k == part_key::port_path) return took(take(value, u.port_path), true);
    if (k == part_key::speed) return took(take(value, u.speed), true);
    if (k == part_key::vid || k == part_key::pid) return took(take(value, text), true);
    if (k == part_key::speed_mbps) return took(value.IsNumber());
    if (k == part_key::usb_version || k == part_key::sysfs_path) return took(take(value, text));
    if (k == key::device_nodes) return took(take_strings(value, nodes));
    return -1;
  });
  if (!ok) return false;
  u.bus = bus;
  out = std::move(u);
  return true;
}

}  // namespace

std::optional<SharingHost> host_of(const Value& doc) {
  const auto* v = json::find(doc, key::host);
  if (!v) return std::nullopt;
  SharingHost h;
  const bool ok = whole(*v, 2, [&](std::string_view k, const Value& value) {
    if (k == part_key::name) return took(take(value, h.name), true);
    if (k == part_key::addresses) return took(take_strings(value, h.addresses), true);
    if (k == part_key::participant_guid) return took(take(value, h.participant_guid));
    return -1;
  });
  if (!ok) return std::nullopt;
  return h;
}

std::optional<DeviceInUse> in_use_of(const Value& doc) {
  const auto* v = json::find(doc, key::in_use);
  if (!v) return std::nullopt;
  DeviceInUse u;
  const bool ok = whole(*v, 2, [&](std::string_view k, const Value& value) {
    if (k == part_key::clients) {
      int n = -1;
      const bool counted = take(value, n) && n >= 0;
      u.clients = static_cast<std::size_t>(std::max(n, 0));
      return took(counted, true);
    }
    if (k == part_key::streaming) return took(take_strings(value, u.streaming), true);
    return -1;
  });
  if (!ok) return std::nullopt;
  return u;
}

Device device_from_json(const Value& doc, std::string text) {
  if (!doc.IsObject()) malformed("a device is not a JSON object");
  Device d;
  for (auto m = doc.MemberBegin(); m != doc.MemberEnd(); ++m) {
    // Compared as a string_view: by length first, which turns most keys away
    // without a memcmp.
    const std::string_view k = name_of(m);
    const Value& v = m->value;
    if (k == key::id) take(v, d.id);
    else if (k == key::source) take_source(v, d.source);
    else if (k == key::sources) {
      std::vector<std::string> sources;
      if (v.IsArray() && !v.Empty() &&
          std::all_of(v.Begin(), v.End(), [](const Value& s) { return s.IsString() && rsd::model::parse_source(
                                                                                         {s.GetString(), s.GetStringLength()}); }))
        d.sources = json::texts(&v);
    } else if (k == key::domain) {
      int domain = 0;
      if (take(v, domain)) d.domain = domain;
    } else if (k == key::topic_root) take(v, d.topic_root);
    else if (k == key::name) take(v, d.name);
    else if (k == key::serial) take(v, d.serial);
    else if (k == key::product_line) take(v, d.product_line);
    else if (k == key::product_id) take(v, d.product_id);
    else if (k == key::fw_version) take(v, d.fw_version);
    else if (k == key::recovery) d.recovery = v.IsBool() && v.GetBool();
    else if (k == key::first_seen) take(v, d.first_seen);
    else if (k == key::last_seen) take(v, d.last_seen);
    else if (k == key::server) {
      ServerInfo s;
      if (take(v, s)) d.server = std::move(s);
    } else if (k == key::usb) {
      UsbInfo u;
      if (take(v, u)) d.usb = std::move(u);
    } else if (k == key::warnings) {
      std::vector<std::string> warnings;
      if (take_strings(v, warnings)) d.warnings = std::move(warnings);
    }
  }
  if (d.id.empty()) malformed("a device has no \"id\"");
  if (d.sources.empty() && !d.source.empty()) d.sources.push_back(d.source);
  if (d.source.empty() && !d.sources.empty()) d.source = d.sources.front();
  d.state = d.recovery ? "recovery" : d.warnings.empty() ? "ok" : "warning";
  if (!d.warnings.empty()) d.warning = d.warnings.front();
  d.json = text.empty() ? json::dump(doc) : std::move(text);
  return d;
}

namespace {

// Each device's text from the spans the parse noted in the body, each checked to be a
// whole {...}; else found by a scan.
std::vector<std::string> device_texts(std::string_view body,
                                      const std::vector<std::pair<std::size_t, std::size_t>>& spans) {
  std::vector<std::string> texts;
  texts.reserve(spans.size());
  for (auto [start, end] : spans) {
    if (start < body.size() && body[start] != '{' && start > 0 && body[start - 1] == '{') --start;
    if (end < body.size() && body[end] == '}') ++end;
    if (start >= end || end > body.size() || body[start] != '{' || body[end - 1] != '}') {
      texts.clear();
      for (auto text : array_member_elements(body, "devices")) texts.emplace_back(text);
      return texts;
    }
    texts.emplace_back(body.substr(start, end - start));
  }
  return texts;
}

}  // namespace

std::optional<std::string> read_device_list(const std::string& body, const std::string& path, DeviceList& out) {
  json::Document doc;
  std::vector<std::pair<std::size_t, std::size_t>> spans;
  if (auto problem = json::parse(body, doc, "devices", &spans)) {
    if (problem->find("nested") != std::string::npos) return "GET " + path + " returned " + *problem;
    return "GET " + path + " did not return a JSON object";
  }
  if (!doc.IsObject()) return "GET " + path + " did not return a JSON object";
  const auto* devices = json::find(doc, "devices");
  if (!devices || !devices->IsArray()) return "no \"devices\" array";
  auto texts = device_texts(body, spans);
  const bool texts_fit = texts.size() == devices->Size();
  out.devices.clear();
  out.devices.reserve(devices->Size());
  for (const auto& d : devices->GetArray()) {
    if (!d.IsObject()) return "a device is not a JSON object";
    const std::size_t i = out.devices.size();
    out.devices.push_back(device_from_json(d, texts_fit ? std::move(texts[i]) : std::string()));
  }
  out.generation = json::unsigned_integer(json::find(doc, "generation")).value_or(0);
  out.complete = reports_complete(doc);
  return std::nullopt;
}

}  // namespace rsdiscovery::detail
