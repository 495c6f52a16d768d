#include "dds/device_info.hpp"

#include <string_view>

namespace rsd::dds {
namespace {

using nlohmann::json;

// Builds the DOM like nlohmann's own parser but gives up past kMaxDepth, before
// the (recursive) CBOR reader can descend further: a few KiB of '[' must not
// cost stack depth on a DDS listener thread.
class DepthLimitedSax : public nlohmann::json_sax<json> {
 public:
  explicit DepthLimitedSax(json& root) : dom_(root, false) {}
  bool too_deep() const { return too_deep_; }

  bool null() override { return dom_.null(); }
  bool boolean(bool v) override { return dom_.boolean(v); }
  bool number_integer(number_integer_t v) override { return dom_.number_integer(v); }
  bool number_unsigned(number_unsigned_t v) override { return dom_.number_unsigned(v); }
  bool number_float(number_float_t v, const string_t& s) override { return dom_.number_float(v, s); }
  bool string(string_t& v) override { return dom_.string(v); }
  bool binary(binary_t& v) override { return dom_.binary(v); }
  bool start_object(std::size_t n) override { return enter() && dom_.start_object(n); }
  bool key(string_t& v) override { return dom_.key(v); }
  bool end_object() override { --depth_; return dom_.end_object(); }
  bool start_array(std::size_t n) override { return enter() && dom_.start_array(n); }
  bool end_array() override { --depth_; return dom_.end_array(); }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override {
    return false;
  }

 private:
  bool enter() {
    if (++depth_ > kMaxDepth) too_deep_ = true;
    return !too_deep_;
  }
  nlohmann::detail::json_sax_dom_parser<json> dom_;
  int depth_ = 0;
  bool too_deep_ = false;
};

// CBOR text strings are not checked by the reader; JSON text is checked before
// parsing. Either way nothing that cannot be serialised again enters the table.
bool all_strings_utf8(const json& j) {
  if (j.is_string()) return is_valid_utf8(j.get_ref<const std::string&>());
  if (j.is_object()) {
    for (const auto& [k, v] : j.items())
      if (!is_valid_utf8(k) || !all_strings_utf8(v)) return false;
  } else if (j.is_array()) {
    for (const auto& v : j)
      if (!all_strings_utf8(v)) return false;
  }
  return true;
}

bool nonempty_string(const json& obj, const char* key) {
  auto it = obj.find(key);
  return it != obj.end() && it->is_string() && !it->get_ref<const std::string&>().empty();
}

}  // namespace

bool is_valid_utf8(std::string_view s) {
  std::size_t i = 0;
  const std::size_t n = s.size();
  while (i < n) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) { ++i; continue; }
    int len;
    std::uint32_t cp;
    if ((c & 0xE0) == 0xC0) { len = 2; cp = c & 0x1Fu; }
    else if ((c & 0xF0) == 0xE0) { len = 3; cp = c & 0x0Fu; }
    else if ((c & 0xF8) == 0xF0) { len = 4; cp = c & 0x07u; }
    else return false;
    if (i + static_cast<std::size_t>(len) > n) return false;
    for (int k = 1; k < len; ++k) {
      const auto cc = static_cast<unsigned char>(s[i + static_cast<std::size_t>(k)]);
      if ((cc & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (cc & 0x3Fu);
    }
    static constexpr std::uint32_t kMinForLen[] = {0, 0, 0x80, 0x800, 0x10000};
    if (cp < kMinForLen[len] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    i += static_cast<std::size_t>(len);
  }
  return true;
}

std::variant<nlohmann::json, Rejected> parse_flexible(std::int32_t format, std::span<const std::uint8_t> data) {
  if (format == static_cast<std::int32_t>(DataFormat::custom))
    return Rejected{"custom-format", "CUSTOM data format carries no JSON or CBOR document"};
  if (format != static_cast<std::int32_t>(DataFormat::json) &&
      format != static_cast<std::int32_t>(DataFormat::cbor))
    return Rejected{"unknown-format", "data_format " + std::to_string(format)};
  if (data.size() > kMaxPayload)
    return Rejected{"too-large", std::to_string(data.size()) + " bytes"};
  if (data.empty()) return Rejected{"empty", "no data"};

  json doc;
  DepthLimitedSax sax(doc);
  bool ok;
  if (format == static_cast<std::int32_t>(DataFormat::json)) {
    std::string_view text(reinterpret_cast<const char*>(data.data()), data.size());
    // A C-string writer may send its terminator; forgive that, but a NUL inside
    // the text would make the parser stop early and take half a message.
    while (!text.empty() && text.back() == '\0') text.remove_suffix(1);
    if (text.find('\0') != std::string_view::npos) return Rejected{"not-json", "NUL inside JSON text"};
    if (text.empty()) return Rejected{"empty", "only NUL bytes"};
    if (!is_valid_utf8(text)) return Rejected{"invalid-utf8", "JSON text is not UTF-8"};
    try {
      ok = json::sax_parse(text.begin(), text.end(), &sax, nlohmann::json::input_format_t::json, true);
    } catch (const json::exception&) {
      ok = false;
    }
    if (sax.too_deep()) return Rejected{"too-deep", "nesting over " + std::to_string(kMaxDepth)};
    if (!ok) return Rejected{"not-json", "JSON text does not parse"};
  } else {
    // The reader throws, rather than reporting, on some inputs (an array header
    // claiming 2^62 elements); on a DDS listener thread that would end the daemon.
    try {
      ok = json::sax_parse(data.begin(), data.end(), &sax, nlohmann::json::input_format_t::cbor, true);
    } catch (const json::exception&) {
      ok = false;
    }
    if (sax.too_deep()) return Rejected{"too-deep", "nesting over " + std::to_string(kMaxDepth)};
    if (!ok) return Rejected{"bad-cbor", "CBOR does not decode"};
    if (!all_strings_utf8(doc)) return Rejected{"invalid-utf8", "CBOR text string is not UTF-8"};
  }
  return doc;
}

Parsed parse_device_info(std::int32_t format, std::span<const std::uint8_t> data) {
  auto parsed = parse_flexible(format, data);
  if (auto* bad = std::get_if<Rejected>(&parsed)) return std::move(*bad);
  json& doc = std::get<json>(parsed);
  if (!doc.is_object()) return Rejected{"not-object", std::string("top level is ") + doc.type_name()};
  if (!nonempty_string(doc, "topic-root"))
    return Rejected{"missing-topic-root", "no string topic-root"};
  std::string topic_root = doc["topic-root"].get<std::string>();
  if (doc.contains("stopping")) return Stopping{std::move(topic_root)};
  if (!nonempty_string(doc, "name")) return Rejected{"missing-name", "no string name"};
  return DeviceInfo{std::move(doc), std::move(topic_root)};
}

std::string device_id(int domain, const std::string& topic_root) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string id = "dds-" + std::to_string(domain) + "-";
  for (const char ch : topic_root) {
    const auto c = static_cast<unsigned char>(ch);
    if ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-') {
      id += ch;
    } else if (c == '/') {
      id += '.';
    } else {
      id += '~';
      id += kHex[c >> 4];
      id += kHex[c & 0xF];
    }
  }
  return id;
}

}  // namespace rsd::dds
