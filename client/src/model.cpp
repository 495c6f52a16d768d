// The daemon's JSON documents as the public types, and the small pure helpers.
#include "internal.hpp"

#include <cstring>

#include "rsd_model/removal.hpp"
#include "rsd_model/spelling.hpp"

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
// part of a cold `rs-discover list` (callgrind). The list reader cuts each device's
// text at the spans its parse notes (device_list.cpp); this scan is its fallback.
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

bool same_device(std::string_view a_text, std::string_view b_text) {
  const auto a = json::parse_or_null(a_text), b = json::parse_or_null(b_text);
  if (!a.IsObject() || !b.IsObject()) return a_text == b_text;
  // Not the camera's: the times move on every announcement, and an event's reason or
  // arrival rides on the document it carries, not on the one a list gives.
  const auto ignored = [](std::string_view k) {
    return k == rsd::model::key::last_seen || k == rsd::model::key::first_seen || k == rsd::model::key::reason ||
           k == rsd::model::key::arrival || k == rsd::model::key::away_since;
  };
  const auto covered = [&](const json::Value& x, const json::Value& y) {
    for (const auto& m : x.GetObject()) {
      const std::string_view k(m.name.GetString(), m.name.GetStringLength());
      if (ignored(k)) continue;
      const auto* other = json::find(y, k);
      if (!other || *other != m.value) return false;
    }
    return true;
  };
  return covered(a, b) && covered(b, a);
}

bool reports_complete(const json::Value& doc) {
  return json::boolean(json::find(doc, "complete")).value_or(true);
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
  const auto doc = json::parse_or_null(json);
  const auto* v = json::find(doc, key);
  return v ? json::dump(*v) : std::string();
}

namespace {

// A document the caller hands in as text: refused as not JSON before it is read.
json::Document parsed(const std::string& text) {
  json::Document doc;
  if (json::parse(text, doc)) throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd: not JSON");
  return doc;
}

// A device's document read again, for what Device has no field for: nothing of it
// when it is not JSON or not an object.
detail::DeviceDocument read(const Device& device) {
  detail::DeviceDocument doc;
  const auto why = detail::read_device(device.json, doc);
  return why && why != detail::Unread::no_id ? detail::DeviceDocument() : doc;
}

}  // namespace

Description parse_description(const std::string& json_text) {
  return detail::description_from_json(parsed(json_text), json_text);
}

std::optional<SharingHost> sharing_host(const Device& device) {
  if (device.source != "remote-usb") return std::nullopt;
  // A remote-usb device without a readable "host": a value with an empty name.
  return read(device).host.value_or(SharingHost{});
}

std::optional<DeviceInUse> in_use_of(const Device& device) { return read(device).in_use; }

Device parse_device(const std::string& json_text) { return detail::device_from_text(json_text); }

}  // namespace rsdiscovery
