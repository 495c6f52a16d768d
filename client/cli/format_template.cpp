// rs-discover --format: the template of {fields}, the fields a device and a participant
// have, and printing devices through a template.
#include "common.hpp"

#include <algorithm>

namespace rsdiscover {

const std::vector<std::string>& device_fields() {
  static const std::vector<std::string> fields = {
      "id", "name", "serial", "product-line", "product-id", "fw-version", "topic-root", "source", "sources",
      "domain", "recovery", "warnings", "merged-into", "first-seen", "last-seen", "server",
      "server.participant-name", "server.participant-guid", "server.writer-guid", "server.addresses", "usb",
      "usb.bus", "usb.address", "usb.port-path", "usb.speed", "usb.speed-mbps", "usb.vid", "usb.pid",
      "usb.usb-version", "usb.sysfs-path", "host", "host.name", "host.addresses", "host.participant-guid", "state",
      "location", "address", "age"};
  return fields;
}

const std::vector<std::string>& participant_fields() {
  static const std::vector<std::string> fields = {
      "domain", "guid", "name", "vendor", "vendor-id", "addresses", "host", "process", "pid", "lease-seconds",
      "state", "first-seen", "last-seen", "device-info-writers", "devices", "silent-writers", "never-announced",
      "topic-roots", "endpoints"};
  return fields;
}

std::optional<std::string> device_computed(const rsdiscovery::Device& d, const std::string& field) {
  if (field == "state") return device_state(d);
  if (field == "location") return device_location(d);
  if (field == "address") return device_addresses(d);
  if (field == "sources") return device_sources(d);
  if (field == "age") return age_since(d.first_seen);
  return std::nullopt;
}

void print_formatted(const Template& tmpl, const std::vector<rsdiscovery::Device>& devices) {
  std::vector<rsdiscovery::json::Document> docs;
  std::vector<const rsdiscovery::json::Value*> values;
  docs.reserve(devices.size());
  values.reserve(devices.size());
  for (const auto& d : devices) values.push_back(&docs.emplace_back(rsdiscovery::json::parse_or_null(d.json)));
  tmpl.check(values);
  std::string out;
  for (std::size_t i = 0; i < devices.size(); ++i)
    out += tmpl.render(docs[i], [&](const std::string& f) { return device_computed(devices[i], f); }) + "\n";
  std::fputs(out.c_str(), stdout);
}

std::string value_text(const rsdiscovery::json::Value& v) {
  if (v.IsNull()) return "";
  if (v.IsString()) return std::string(v.GetString(), v.GetStringLength());
  if (v.IsArray()) {
    std::vector<std::string> parts;
    for (const auto& item : v.GetArray()) parts.push_back(value_text(item));
    return join(parts, ",");
  }
  return rsdiscovery::json::dump(v);
}

namespace {
// The value at a dotted path ("server.addresses"), or nullptr.
const rsdiscovery::json::Value* at_path(const rsdiscovery::json::Value& doc, const std::string& path) {
  const rsdiscovery::json::Value* v = &doc;
  std::size_t from = 0;
  for (;;) {
    const auto dot = path.find('.', from);
    const auto key = std::string_view(path).substr(from, dot == std::string::npos ? std::string::npos : dot - from);
    v = rsdiscovery::json::find(*v, key);
    if (!v || dot == std::string::npos) return v;
    from = dot + 1;
  }
}
}  // namespace

Template::Template(const std::string& tmpl, std::vector<std::string> known) : known_(std::move(known)) {
  std::string literal;
  for (std::size_t i = 0; i < tmpl.size(); ++i) {
    const char c = tmpl[i];
    const char next = i + 1 < tmpl.size() ? tmpl[i + 1] : '\0';
    if ((c == '{' && next == '{') || (c == '}' && next == '}')) {
      literal += c;
      ++i;
    } else if (c == '{') {
      const auto close = tmpl.find('}', i);
      if (close == std::string::npos) throw UsageError("--format: '{' at " + std::to_string(i + 1) + " is never closed");
      if (!literal.empty()) pieces_.push_back({false, std::move(literal)});
      literal.clear();
      pieces_.push_back({true, tmpl.substr(i + 1, close - i - 1)});
      i = close;
    } else if (c == '}') {
      throw UsageError("--format: '}' at " + std::to_string(i + 1) + " closes nothing (write }} for a brace)");
    } else if (c == '\\' && (next == 'n' || next == 't')) {
      literal += next == 'n' ? '\n' : '\t';
      ++i;
    } else {
      literal += c;
    }
  }
  if (!literal.empty()) pieces_.push_back({false, std::move(literal)});
}

void Template::check(const std::vector<const rsdiscovery::json::Value*>& docs) const {
  for (const auto& piece : pieces_) {
    if (!piece.field) continue;
    if (std::find(known_.begin(), known_.end(), piece.text) != known_.end()) continue;
    if (std::any_of(docs.begin(), docs.end(),
                    [&](const rsdiscovery::json::Value* d) { return d && at_path(*d, piece.text); }))
      continue;
    throw UsageError("--format: unknown field '{" + piece.text + "}'; the fields are {" + join(known_, "}, {") +
                     "} (and any other key a document has)");
  }
}

std::string Template::render(const rsdiscovery::json::Value& doc,
                             const std::function<std::optional<std::string>(const std::string&)>& computed) const {
  std::string out;
  for (const auto& piece : pieces_) {
    if (!piece.field) {
      out += piece.text;
      continue;
    }
    if (computed)
      if (auto v = computed(piece.text)) {
        out += *v;
        continue;
      }
    if (const auto* v = at_path(doc, piece.text)) out += value_text(*v);
  }
  return out;
}

}  // namespace rsdiscover
