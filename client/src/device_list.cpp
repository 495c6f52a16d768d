// GET /v1/devices' reply into a DeviceList: parsed with RapidJSON and read through the
// model's one device reader (rsd_model/device_reader.hpp).
//
// Why not nlohmann here, as everywhere else: a cold `rs-discover list` spent most of
// its instructions in nlohmann's parser, whose lexer alone (a SAX parse doing
// nothing) is slower than RapidJSON building its whole tree
// (bench/results/profile-cli-list.txt). It is header-only, so the CLI loads nothing
// more for it.
#include "internal.hpp"

#include "rsd_model/device_reader.hpp"

#include <rapidjson/document.h>
#include <rapidjson/stringbuffer.h>
#include <rapidjson/writer.h>

#include <cstdint>
#include <cstring>

namespace rsdiscovery::detail {

namespace {

using nlohmann::json;

// RapidJSON's tree as a view of the model's reader.
class RapidView {
 public:
  explicit RapidView(const rapidjson::Value& v) : v_(&v) {}
  bool is_object() const { return v_->IsObject(); }
  bool is_array() const { return v_->IsArray(); }
  bool is_string() const { return v_->IsString(); }
  bool is_bool() const { return v_->IsBool(); }
  bool is_integer() const { return v_->IsInt64() || v_->IsUint64(); }
  bool is_number() const { return v_->IsNumber(); }
  std::string_view text() const { return {v_->GetString(), v_->GetStringLength()}; }
  bool boolean() const { return v_->GetBool(); }
  bool integer(std::int64_t& out) const {
    if (!v_->IsInt64()) return false;  // a uint64 above INT64_MAX
    out = v_->GetInt64();
    return true;
  }
  double number() const { return v_->GetDouble(); }
  std::size_t size() const { return v_->Size(); }
  template <class F>
  bool each_element(F&& f) const {
    for (const auto& e : v_->GetArray())
      if (!f(RapidView(e))) return false;
    return true;
  }
  template <class F>
  bool each_member(F&& f) const {
    for (const auto& m : v_->GetObject())
      if (!f(std::string_view(m.name.GetString(), m.name.GetStringLength()), RapidView(m.value))) return false;
    return true;
  }
  // Written out and read back by nlohmann: only keys the model does not know (rare)
  // take this way. Writing recurses, over at most DepthLimited::kMaxDepth levels.
  json to_json() const {
    rapidjson::StringBuffer buffer;
    rapidjson::Writer<rapidjson::StringBuffer> writer(buffer);
    v_->Accept(writer);
    return json::parse(std::string_view(buffer.GetString(), buffer.GetSize()));
  }

 private:
  const rapidjson::Value* v_;
};

// The list document from either tree (see has_long_exponent): the same checks.
template <class V>
std::optional<std::string> read_list(const V& doc, std::vector<std::string>& texts,
                                     const std::string& path, DeviceList& out) {
  if (!doc.is_object()) return "GET " + path + " did not return a JSON object";
  bool has_devices = false;
  std::optional<std::string> problem;
  out.complete = true;  // no "complete": a daemon older than the field (reports_complete)
  doc.each_member([&](std::string_view key, const V& value) {
    if (key == "devices") {
      if (!value.is_array()) return true;  // said below, as a missing array
      has_devices = true;
      out.devices.clear();
      out.devices.reserve(value.size());
      // Each text as the daemon sent it, when the scan found as many as the parser.
      const bool texts_fit = texts.size() == value.size();
      value.each_element([&](const V& d) {
        if (!d.is_object()) {
          problem = "a device is not a JSON object";
          return false;
        }
        const std::size_t i = out.devices.size();
        out.devices.push_back(
            device_from_model(rsd::model::read_device(d), texts_fit ? std::move(texts[i]) : d.to_json().dump()));
        return true;
      });
    } else if (key == "generation") {
      std::int64_t g = 0;
      if (value.is_integer() && value.integer(g) && g >= 0) out.generation = static_cast<std::uint64_t>(g);
    } else if (key == "complete") {
      out.complete = !value.is_bool() || value.boolean();
    }
    return !problem;
  });
  if (problem) return problem;
  if (!has_devices) return "no \"devices\" array";
  return std::nullopt;
}

// RapidJSON's tree builder (the document's own handler) with a bound on nesting: the
// tree is read recursively afterwards (a key the model does not know is written out
// again), and no list of the daemon's comes near it (a device-info is cut at 16
// levels: daemon/dds/device_info.hpp). On the way it notes where each object of the
// top-level "devices" array starts and ends, for Device::json: a scan of the body
// for them before the parse (array_member_elements) was a twentieth of a cold
// `rs-discover list` (bench/results/profile-cli-list.txt).
class DepthLimited {
 public:
  static constexpr int kMaxDepth = 64;
  DepthLimited(rapidjson::Document& doc, rapidjson::InsituStringStream& stream) : doc_(doc), stream_(stream) {}
  bool too_deep() const { return too_deep_; }
  // [start, end) of each device object in the body, as the stream stood at its braces:
  // at the brace or just past it (the reader calls before or after taking it).
  const std::vector<std::pair<std::size_t, std::size_t>>& spans() const { return spans_; }

  bool Null() { return doc_.Null(); }
  bool Bool(bool b) { return doc_.Bool(b); }
  bool Int(int i) { return doc_.Int(i); }
  bool Uint(unsigned u) { return doc_.Uint(u); }
  bool Int64(std::int64_t i) { return doc_.Int64(i); }
  bool Uint64(std::uint64_t u) { return doc_.Uint64(u); }
  bool Double(double d) { return doc_.Double(d); }
  bool RawNumber(const char* str, rapidjson::SizeType length, bool copy) { return doc_.RawNumber(str, length, copy); }
  bool String(const char* str, rapidjson::SizeType length, bool copy) { return doc_.String(str, length, copy); }
  bool Key(const char* str, rapidjson::SizeType length, bool copy) {
    if (depth_ == 1) in_devices_ = std::string_view(str, length) == "devices";
    return doc_.Key(str, length, copy);
  }
  bool StartObject() {
    if (!enter()) return false;
    if (depth_ == 3 && in_devices_) spans_.emplace_back(stream_.Tell(), 0);
    return doc_.StartObject();
  }
  bool EndObject(rapidjson::SizeType members) {
    if (depth_ == 3 && in_devices_ && !spans_.empty()) spans_.back().second = stream_.Tell();
    return leave() && doc_.EndObject(members);
  }
  bool StartArray() { return enter() && doc_.StartArray(); }
  bool EndArray(rapidjson::SizeType elements) { return leave() && doc_.EndArray(elements); }

 private:
  bool enter() {
    too_deep_ = ++depth_ > kMaxDepth;
    return !too_deep_;
  }
  bool leave() {
    --depth_;
    return true;
  }
  rapidjson::Document& doc_;
  rapidjson::InsituStringStream& stream_;
  int depth_ = 0;
  bool too_deep_ = false;
  bool in_devices_ = false;  // the last top-level key was "devices"
  std::vector<std::pair<std::size_t, std::size_t>> spans_;
};

// Each device's text from the spans the parse noted in `original` (the body before
// the parse rewrote it), each checked to be a whole {...}; else found by a scan.
std::vector<std::string> device_texts(std::string_view original,
                                      const std::vector<std::pair<std::size_t, std::size_t>>& spans) {
  std::vector<std::string> texts;
  texts.reserve(spans.size());
  for (auto [start, end] : spans) {
    if (start < original.size() && original[start] != '{' && start > 0 && original[start - 1] == '{') --start;
    if (end < original.size() && original[end] == '}') ++end;
    if (start >= end || end > original.size() || original[start] != '{' || original[end - 1] != '}') {
      texts.clear();
      for (auto text : array_member_elements(original, "devices")) texts.emplace_back(text);
      return texts;
    }
    texts.emplace_back(original.substr(start, end - start));
  }
  return texts;
}

// RapidJSON 1.1.0 as bookworm ships it (1.1.0+dfsg2-7.1) adds a negative exponent of
// nine digits to the count of a fraction's digits in an int, which a fraction of some
// two billion digits underflows (CVE-2024-38517; trixie's 7.4 is patched). The daemon
// never writes an exponent of more than three digits (it writes doubles the shortest
// way): a body with a longer one anywhere, inside a string too (this is only a hint),
// is read by nlohmann instead, and RapidJSON never meets such a number.
bool has_long_exponent(std::string_view text) {
  const auto digit = [&](std::size_t j) { return j < text.size() && text[j] >= '0' && text[j] <= '9'; };
  // Four digits in a row after an 'e' or 'E' and an optional sign; memchr to each
  // letter (a loop over every byte was a seventh of a cold list's instructions).
  for (const char letter : {'e', 'E'}) {
    for (auto i = text.find(letter); i != std::string_view::npos; i = text.find(letter, i + 1)) {
      std::size_t j = i + 1;
      if (j < text.size() && (text[j] == '+' || text[j] == '-')) ++j;
      if (digit(j) && digit(j + 1) && digit(j + 2) && digit(j + 3)) return true;
    }
  }
  return false;
}

bool is_ascii(std::string_view text) {
  std::uint64_t high = 0;  // eight bytes at a time: the loop is most of what a check costs
  std::size_t i = 0;
  for (; i + 8 <= text.size(); i += 8) {
    std::uint64_t word;
    std::memcpy(&word, text.data() + i, 8);
    high |= word;
  }
  for (; i < text.size(); ++i) high |= static_cast<unsigned char>(text[i]);
  return (high & 0x8080808080808080ULL) == 0;
}

}  // namespace

std::optional<std::string> read_device_list(std::string& body, const std::string& path, DeviceList& out) {
  // Strict as nlohmann is (the same documents refused: numbers beyond a double, lone
  // surrogates, control characters, trailing text; unit-tested): one value, and valid
  // UTF-8 only, which RapidJSON checks byte by byte (a quarter of a cold list's
  // instructions): a body of ASCII alone, the usual one, cannot be invalid and skips
  // it. Iterative, so the parse itself never recurses. In place: strings are not
  // copied out one by one.
  constexpr unsigned flags =
      rapidjson::kParseInsituFlag | rapidjson::kParseIterativeFlag | rapidjson::kParseFullPrecisionFlag;
  // In place, the parse stops at a NUL as at the end; JSON has none outside strings,
  // nor raw inside them.
  if (body.find('\0') != std::string::npos) return "GET " + path + " did not return a JSON object";
  if (has_long_exponent(body)) {
    std::vector<std::string> texts;  // each device's text as the daemon sent it
    for (auto text : array_member_elements(body, "devices")) texts.emplace_back(text);
    const auto tree = json::parse(body, nullptr, false);
    if (tree.is_discarded()) return "GET " + path + " did not return a JSON object";
    return read_list(rsd::model::JsonView(tree), texts, path, out);
  }
  // Each device's text as the daemon sent it is cut from this copy: the parse
  // rewrites the body.
  const std::string original = body;
  rapidjson::Document doc;
  rapidjson::InsituStringStream stream(body.data());
  DepthLimited builder(doc, stream);
  rapidjson::Reader reader;
  const bool ascii = is_ascii(body);
  auto parse = [&](rapidjson::Document&) {
    const auto result = ascii ? reader.Parse<flags>(stream, builder)
                              : reader.Parse<flags | rapidjson::kParseValidateEncodingFlag>(stream, builder);
    return !result.IsError();
  };
  doc.Populate(parse);
  if (builder.too_deep())
    return "GET " + path + " returned a document nested deeper than " + std::to_string(DepthLimited::kMaxDepth) +
           " levels";
  if (reader.HasParseError()) return "GET " + path + " did not return a JSON object";
  auto texts = device_texts(original, builder.spans());
  return read_list(RapidView(doc), texts, path, out);
}

}  // namespace rsdiscovery::detail
