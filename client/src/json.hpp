// The client's JSON: RapidJSON, the one JSON library of librsdiscovery and rs-discover,
// behind the few calls they make. Why RapidJSON: a cold `rs-discover list` spent most
// of its instructions parsing, and nlohmann's lexer alone is slower than RapidJSON
// building its whole tree (bench/results/profile-cli-list.txt). It is header-only:
// nothing more is loaded at a cold start.
#pragma once

// RapidJSON's 16-byte scans for strings and whitespace (SSE2 is in every x86-64).
// They read whole aligned blocks, up to 15 bytes past a text's end: parse() gives
// them a copy with that room. Defined here, before RapidJSON is first included, so
// that every file of the client sees one definition of its reader.
#if defined(__SSE2__) && !defined(RAPIDJSON_SSE2)
#define RAPIDJSON_SSE2
#endif
#include <rapidjson/document.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace rsdiscovery::json {

using Value = rapidjson::Value;
using Document = rapidjson::Document;

// Deeper documents are refused: what is read is read recursively (written out
// again, looked through), and nothing the daemon writes comes near (a device-info is
// cut at 16 levels: daemon/dds/device_info.hpp).
inline constexpr int kMaxDepth = 64;

// What a parse finds, told in the order of the text: for a reader that builds its
// own values and needs no tree (device_list.cpp). Numbers come as the kind they are
// written as: a whole number below zero that fits 64 bits, a whole number from zero
// that fits 64 bits, or any other (as a double). For an object, `at` is where in the
// text the reader stands as it tells: on its brace or just past it (the reader takes
// the brace before it tells, or after).
class Events {
 public:
  virtual void null() = 0;
  virtual void boolean(bool b) = 0;
  virtual void integer(std::int64_t i) = 0;
  virtual void unsigned_integer(std::uint64_t u) = 0;
  virtual void number(double d) = 0;
  virtual void string(std::string_view s) = 0;
  virtual void key(std::string_view k) = 0;
  virtual void start_object(std::size_t at) = 0;
  virtual void end_object(std::size_t at, std::size_t members) = 0;
  virtual void start_array() = 0;
  virtual void end_array(std::size_t elements) = 0;

 protected:
  ~Events() = default;
};

// Parses `text` as one JSON value, as strictly as nlohmann does (numbers beyond a
// double, lone surrogates, control characters, invalid UTF-8, trailing text and NULs
// are refused; unit-tested), telling `events` what it finds. Returns why not, said
// for a user, or nothing; when it says why not, `events` may have been told of a
// part of the text. `text` itself is not written to (the parse is in place on a copy).
std::optional<std::string> parse(std::string_view text, Events& events);
// The same parse into a tree.
std::optional<std::string> parse(std::string_view text, Document& out);
// A Null document when `text` is not JSON, nothing said why (for text the daemon
// wrote and the library already checked, such as Device::json).
Document parse_or_null(std::string_view text);

// The member `key` of `object`; nullptr when `object` is not an object or has none.
const Value* find(const Value& object, std::string_view key);
inline const Value* find(const Value* object, std::string_view key) { return object ? find(*object, key) : nullptr; }

// A value as the type asked for; nothing when it is absent (nullptr) or of another type.
std::optional<std::string_view> text(const Value* v);
std::optional<std::int64_t> integer(const Value* v);            // a whole number within int64
std::optional<std::uint64_t> unsigned_integer(const Value* v);  // a whole number >= 0
std::optional<double> number(const Value* v);                   // any number
std::optional<bool> boolean(const Value* v);
// text(v) as a string, or `fallback`.
std::string text_or(const Value* v, std::string_view fallback = {});
// Every string element of an array, in order (other elements skipped); empty when
// `v` is not an array.
std::vector<std::string> texts(const Value* v);

// `v` written out as nlohmann writes it, numbers and escapes too: compactly, or laid
// out as its dump(indent) lays it out.
std::string dump(const Value& v);
std::string dump(const Value& v, int indent);
// `text` as a JSON string literal, quotes included.
std::string quote(std::string_view text);

}  // namespace rsdiscovery::json
