// RapidJSON behind json.hpp: a strict, bounded parse, typed reads and the writers.
#include "json.hpp"

#include <rapidjson/stream.h>
#include <rapidjson/prettywriter.h>
#include <rapidjson/stringbuffer.h>
#include <rapidjson/writer.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <system_error>
#include <cmath>
#include <cstdio>
#include <cstring>

#include <locale.h>
#include <stdlib.h>

namespace rsdiscovery::json {

namespace {

// Numbers are read and written in the "C" locale, whatever the program's is (its
// decimal point is '.'). With strtod_l and snprintf, not std::from_chars and
// std::to_chars: libstdc++'s ask libm for the rounding mode, and loading libm for
// that alone was a large part of rs-discover's cold start (bench/).
locale_t c_numeric() {
  static const locale_t c = newlocale(LC_NUMERIC_MASK, "C", locale_t{});
  return c;
}

// RapidJSON 1.1 takes the escape of a lone low surrogate ("\udc00") and writes the
// UTF-8 form of the surrogate itself, which is not UTF-8 (and what RapidJSON then
// writes out it refuses to read back): nlohmann refuses such text, and so does this.
// Such a form starts 0xED 0xA0-0xBF; raw in the text, validation already refuses it,
// so only a text with a \u escape is looked through.
bool has_surrogate(const char* str, std::size_t length) {
  for (const void* p = std::memchr(str, '\xED', length); p;) {
    const auto i = static_cast<std::size_t>(static_cast<const char*>(p) - str);
    if (i + 1 < length && static_cast<unsigned char>(str[i + 1]) >= 0xA0) return true;
    p = i + 1 < length ? std::memchr(str + i + 1, '\xED', length - i - 1) : nullptr;
  }
  return false;
}

// RapidJSON's reader handler: tells `events` what the reader finds, with a bound on
// nesting, numbers read exactly and lone surrogates refused.
template <class Stream>
class Handler {
 public:
  Handler(Events& events, Stream& stream, bool escapes) : events_(events), stream_(stream), escapes_(escapes) {}
  bool too_deep() const { return too_deep_; }

  bool Null() { return events_.null(), true; }
  bool Bool(bool b) { return events_.boolean(b), true; }
  // Never called with kParseNumbersAsStringsFlag (see kFlags), which RawNumber takes
  // instead; the reader's concept asks for them.
  bool Int(int i) { return events_.integer(i), true; }
  bool Uint(unsigned u) { return events_.unsigned_integer(u), true; }
  bool Int64(std::int64_t i) { return events_.integer(i), true; }
  bool Uint64(std::uint64_t u) { return events_.unsigned_integer(u), true; }
  bool Double(double d) { return events_.number(d), true; }
  bool RawNumber(const char* str, rapidjson::SizeType length, bool) {
    const std::string_view t(str, length);
    if (t.find_first_of(".eE") == std::string_view::npos) {  // a whole number, when it fits 64 bits
      std::int64_t i = 0;
      std::uint64_t u = 0;
      if (t.front() == '-' && std::from_chars(t.data(), t.data() + t.size(), i).ec == std::errc()) {
        // "-0" is zero, from zero.
        return i < 0 ? events_.integer(i) : events_.unsigned_integer(0), true;
      }
      if (t.front() != '-' && std::from_chars(t.data(), t.data() + t.size(), u).ec == std::errc())
        return events_.unsigned_integer(u), true;
    }
    // Exactly, as nlohmann's strtod reads it: too small for a double is 0 or the
    // nearest subnormal; too large is refused, as nlohmann refuses it.
    const std::string text(t);
    char* end = nullptr;
    const double d = strtod_l(text.c_str(), &end, c_numeric());
    if (end != text.c_str() + text.size() || !std::isfinite(d)) return false;
    return events_.number(d), true;
  }
  bool String(const char* str, rapidjson::SizeType length, bool) {
    if (escapes_ && has_surrogate(str, length)) return false;
    return events_.string({str, length}), true;
  }
  bool Key(const char* str, rapidjson::SizeType length, bool) {
    if (escapes_ && has_surrogate(str, length)) return false;
    return events_.key({str, length}), true;
  }
  bool StartObject() { return enter() && (events_.start_object(stream_.Tell()), true); }
  bool EndObject(rapidjson::SizeType members) { return leave(), events_.end_object(stream_.Tell(), members), true; }
  bool StartArray() { return enter() && (events_.start_array(), true); }
  bool EndArray(rapidjson::SizeType elements) { return leave(), events_.end_array(elements), true; }

 private:
  bool enter() {
    too_deep_ = ++depth_ > kMaxDepth;
    return !too_deep_;
  }
  void leave() { --depth_; }
  Events& events_;
  Stream& stream_;
  const bool escapes_;  // the text has a \u escape
  int depth_ = 0;
  bool too_deep_ = false;
};

// The tree: each event handed on to the document's own handler, which builds it.
class TreeEvents final : public Events {
 public:
  explicit TreeEvents(Document& doc) : doc_(doc) {}
  void null() override { doc_.Null(); }
  void boolean(bool b) override { doc_.Bool(b); }
  void integer(std::int64_t i) override { doc_.Int64(i); }
  void unsigned_integer(std::uint64_t u) override { doc_.Uint64(u); }
  void number(double d) override { doc_.Double(d); }
  void string(std::string_view s) override { doc_.String(s.data(), size(s), true); }
  void key(std::string_view k) override { doc_.Key(k.data(), size(k), true); }
  void start_object(std::size_t) override { doc_.StartObject(); }
  void end_object(std::size_t, std::size_t members) override {
    doc_.EndObject(static_cast<rapidjson::SizeType>(members));
  }
  void start_array() override { doc_.StartArray(); }
  void end_array(std::size_t elements) override { doc_.EndArray(static_cast<rapidjson::SizeType>(elements)); }

 private:
  static rapidjson::SizeType size(std::string_view s) { return static_cast<rapidjson::SizeType>(s.size()); }
  Document& doc_;
};

// RapidJSON checks UTF-8 byte by byte (a quarter of a cold list's instructions); text
// of ASCII alone, the usual one, cannot be invalid and skips it.
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

// Recursive, which RapidJSON does in fewer instructions than its iterative parse:
// the handler refuses the object or array that would open level kMaxDepth + 1
// before the reader goes into it, so the parse never goes deeper than that,
// whatever the text. The recursive reader hands a number's text over where it
// stands, in place too (the iterative one, in place with full precision, overran
// the heap under fuzz_client_documents). Numbers are converted by strtod_l
// (Handler::RawNumber), exactly, as nlohmann's strtod does, and never by
// RapidJSON 1.1.0 as bookworm ships it (1.1.0+dfsg2-7.1): it adds a negative
// exponent of ten digits to the count of a fraction's digits in an int, which
// underflows (CVE-2024-38517; trixie's 7.4 is patched), and its full-precision strtod
// shifts by the leading zeros of a zero significand (0e-300), which is undefined.
constexpr unsigned kFlags = rapidjson::kParseNumbersAsStringsFlag | rapidjson::kParseInsituFlag;

// A finite double laid out as nlohmann lays it out: in full from 1e-4 to below 1e15,
// a whole one with ".0" ("0.001", "1500.0"), else with a signed exponent of two digits
// or more ("1e-06", "1e+16"; RapidJSON writes "0.000001" and "10000000000000000.0").
// The digits are the fewest that read back as the same double, the nearest of them
// (as std::to_chars gives them; the unit tests hold the two together); nlohmann's
// Grisu2 picks the same ones but for a rare double, where its longer digits name the
// same value.
std::string nlohmann_layout(double d) {
  if (d == 0) return std::signbit(d) ? "-0.0" : "0.0";
  const locale_t c = c_numeric();
  const locale_t previous = uselocale(c);
  std::string digits;
  int exponent = 0;  // of the first digit
  char buffer[64];
  for (int precision = 0; precision <= 16 && digits.empty(); ++precision) {  // 17 digits always read back
    std::snprintf(buffer, sizeof buffer, "%.*e", precision, std::fabs(d));  // "1.5e+100"
    const char* e = std::strchr(buffer, 'e');
    exponent = std::atoi(e + 1);
    std::string nearest;
    for (const char* p = buffer; p < e; ++p)
      if (*p != '.') nearest += *p;
    if (strtod_l(buffer, nullptr, c) == std::fabs(d)) {
      digits = nearest;
      break;
    }
    // The nearest with this many digits may lie just outside the double's interval
    // while its neighbour in the last digit lies inside.
    const unsigned long long m = std::strtoull(nearest.c_str(), nullptr, 10);
    for (const unsigned long long candidate : {m - 1, m + 1}) {
      const std::string text = std::to_string(candidate);
      if (text.size() != nearest.size()) continue;  // another number of digits: another precision's
      std::snprintf(buffer, sizeof buffer, "%se%d", text.c_str(), exponent - precision);
      if (strtod_l(buffer, nullptr, c) == std::fabs(d)) {
        digits = text;
        break;
      }
    }
  }
  uselocale(previous);
  while (digits.size() > 1 && digits.back() == '0') digits.pop_back();
  const int k = static_cast<int>(digits.size());
  const int n = exponent + 1;  // where the point goes, counted from the first digit
  std::string out = d < 0 ? "-" : "";
  if (k <= n && n <= 15) {
    out += digits + std::string(static_cast<std::size_t>(n - k), '0') + ".0";
  } else if (0 < n && n <= 15) {
    out += digits.substr(0, static_cast<std::size_t>(n)) + "." + digits.substr(static_cast<std::size_t>(n));
  } else if (-4 < n && n <= 0) {
    out += "0." + std::string(static_cast<std::size_t>(-n), '0') + digits;
  } else {
    out += digits.substr(0, 1) + (k > 1 ? "." + digits.substr(1) : "") + "e" + (exponent < 0 ? "-" : "+");
    const int magnitude = exponent < 0 ? -exponent : exponent;
    out += (magnitude < 10 ? "0" : "") + std::to_string(magnitude);
  }
  return out;
}

// A number and a string as nlohmann writes them, and so as the daemon's documents
// have them: a double as nlohmann_layout says; a control character as \u001f, in
// lowercase (RapidJSON: \u001F).
template <class Base>
class NlohmannForms : public Base {
 public:
  using Base::Base;

  bool Double(double d) {
    if (!std::isfinite(d)) return Base::Null();  // as nlohmann writes it
    const std::string text = nlohmann_layout(d);
    return Base::RawValue(text.data(), text.size(), rapidjson::kNumberType);
  }

  bool String(const char* text, rapidjson::SizeType length, bool copy = false) {
    const std::string_view s(text, length);
    const auto hex_escaped = [](char c) {
      return static_cast<unsigned char>(c) < 0x20 && c != '\b' && c != '\f' && c != '\n' && c != '\r' && c != '\t';
    };
    if (std::none_of(s.begin(), s.end(), hex_escaped)) return Base::String(text, length, copy);  // the same
    std::string out = "\"";
    for (const char c : s) {
      switch (c) {
        case '"': out += "\\\""; break;
        case '\\': out += "\\\\"; break;
        case '\b': out += "\\b"; break;
        case '\f': out += "\\f"; break;
        case '\n': out += "\\n"; break;
        case '\r': out += "\\r"; break;
        case '\t': out += "\\t"; break;
        default:
          if (hex_escaped(c)) {
            char escaped[8];
            std::snprintf(escaped, sizeof escaped, "\\u%04x", static_cast<unsigned>(c));
            out += escaped;
          } else {
            out += c;
          }
      }
    }
    out += '"';
    return Base::RawValue(out.data(), out.size(), rapidjson::kStringType);
  }
  bool Key(const char* text, rapidjson::SizeType length, bool copy = false) { return String(text, length, copy); }
};

}  // namespace

std::optional<std::string> parse(std::string_view text, Events& events) {
  // A NUL ends the parse as the end of the text would; JSON has none outside strings,
  // nor raw inside them.
  if (std::memchr(text.data(), '\0', text.size())) return "not JSON (a NUL byte)";
  // A backslash is rare in what the daemon writes: memchr finds each (memmem goes byte by byte).
  bool escapes = false;
  for (auto i = text.find('\\'); i != std::string_view::npos && !escapes; i = text.find('\\', i + 2))
    escapes = i + 1 < text.size() && text[i + 1] == 'u';
  // In place, on a copy: each string is unescaped where it stands and handed on from
  // there, where a parse from the text itself copies it byte by byte onto a stack
  // first (most of a list's parse). NUL-terminated, as the reader reads (a NUL inside
  // is refused above), with room past the end for the 16-byte scans (json.hpp).
  std::string copy;
  copy.reserve(text.size() + 32);
  copy.assign(text);
  rapidjson::InsituStringStream stream(copy.data());
  Handler<rapidjson::InsituStringStream> handler(events, stream, escapes);
  rapidjson::Reader reader;
  const auto result = is_ascii(text) ? reader.Parse<kFlags>(stream, handler)
                                     : reader.Parse<kFlags | rapidjson::kParseValidateEncodingFlag>(stream, handler);
  if (handler.too_deep()) return "a document nested deeper than " + std::to_string(kMaxDepth) + " levels";
  if (result.IsError()) return "not JSON";
  return std::nullopt;
}

std::optional<std::string> parse(std::string_view text, Document& out) {
  TreeEvents tree(out);
  std::optional<std::string> problem;
  auto run = [&](Document&) { return !(problem = parse(text, static_cast<Events&>(tree))); };
  out.Populate(run);
  if (problem) out.SetNull();
  return problem;
}

Document parse_or_null(std::string_view text) {
  Document doc;
  if (parse(text, doc)) doc.SetNull();
  return doc;
}

const Value* find(const Value& object, std::string_view key) {
  if (!object.IsObject()) return nullptr;
  for (const auto& m : object.GetObject())
    if (std::string_view(m.name.GetString(), m.name.GetStringLength()) == key) return &m.value;
  return nullptr;
}

std::optional<std::string_view> text(const Value* v) {
  if (!v || !v->IsString()) return std::nullopt;
  return std::string_view(v->GetString(), v->GetStringLength());
}

std::optional<std::int64_t> integer(const Value* v) {
  if (!v || !v->IsInt64()) return std::nullopt;
  return v->GetInt64();
}

std::optional<std::uint64_t> unsigned_integer(const Value* v) {
  if (!v || !v->IsUint64()) return std::nullopt;
  return v->GetUint64();
}

std::optional<double> number(const Value* v) {
  if (!v || !v->IsNumber()) return std::nullopt;
  return v->GetDouble();
}

std::optional<bool> boolean(const Value* v) {
  if (!v || !v->IsBool()) return std::nullopt;
  return v->GetBool();
}

std::string text_or(const Value* v, std::string_view fallback) { return std::string(text(v).value_or(fallback)); }

std::vector<std::string> texts(const Value* v) {
  std::vector<std::string> out;
  if (!v || !v->IsArray()) return out;
  for (const auto& e : v->GetArray())
    if (e.IsString()) out.emplace_back(e.GetString(), e.GetStringLength());
  return out;
}

std::string dump(const Value& v) {
  rapidjson::StringBuffer buffer;
  NlohmannForms<rapidjson::Writer<rapidjson::StringBuffer>> writer(buffer);
  v.Accept(writer);
  return std::string(buffer.GetString(), buffer.GetSize());
}

std::string dump(const Value& v, int indent) {
  if (indent < 0) return dump(v);
  rapidjson::StringBuffer buffer;
  NlohmannForms<rapidjson::PrettyWriter<rapidjson::StringBuffer>> writer(buffer);
  writer.SetIndent(' ', static_cast<unsigned>(indent));
  v.Accept(writer);
  return std::string(buffer.GetString(), buffer.GetSize());
}

std::string quote(std::string_view text) {
  rapidjson::StringBuffer buffer;
  NlohmannForms<rapidjson::Writer<rapidjson::StringBuffer>> writer(buffer);
  writer.String(text.data(), static_cast<rapidjson::SizeType>(text.size()));
  return std::string(buffer.GetString(), buffer.GetSize());
}

}  // namespace rsdiscovery::json
