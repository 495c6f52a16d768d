// Reading the API's status documents strictly (status.cpp, participant.cpp): a
// missing or mistyped key is a MalformedDocument naming the key and the document.
// Internal to rsd_model: not installed, not part of the contract's headers.
#pragma once

#include "rsd_model/status.hpp"  // MalformedDocument

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace rsd::model::read_json {

inline const nlohmann::json& member(const nlohmann::json& doc, const char* name, const char* what) {
  const auto it = doc.find(name);
  if (it == doc.end()) throw MalformedDocument(std::string(what) + " has no \"" + name + "\"");
  return *it;
}

inline std::string text(const nlohmann::json& doc, const char* name, const char* what) {
  const auto& v = member(doc, name, what);
  if (!v.is_string()) throw MalformedDocument(std::string(what) + ": \"" + name + "\" is not a string");
  return v.get<std::string>();
}

inline std::uint64_t count_value(const nlohmann::json& v, const std::string& name, const char* what) {
  if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<std::int64_t>() >= 0))
    throw MalformedDocument(std::string(what) + ": \"" + name + "\" is not a count");
  return v.get<std::uint64_t>();
}

inline std::uint64_t count(const nlohmann::json& doc, const char* name, const char* what) {
  return count_value(member(doc, name, what), name, what);
}

inline bool flag(const nlohmann::json& doc, const char* name, const char* what) {
  const auto& v = member(doc, name, what);
  if (!v.is_boolean()) throw MalformedDocument(std::string(what) + ": \"" + name + "\" is not true or false");
  return v.get<bool>();
}

// A list of strings, each checked.
inline std::vector<std::string> texts(const nlohmann::json& doc, const char* name, const char* what) {
  const auto& v = member(doc, name, what);
  if (!v.is_array()) throw MalformedDocument(std::string(what) + ": \"" + name + "\" is not an array");
  std::vector<std::string> out;
  for (const auto& item : v) {
    if (!item.is_string()) throw MalformedDocument(std::string(what) + ": \"" + name + "\" holds a non-string");
    out.push_back(item.get<std::string>());
  }
  return out;
}

// An optional "pid": a number when given.
inline std::optional<std::int64_t> pid(const nlohmann::json& doc, const char* name, const char* what) {
  const auto it = doc.find(name);
  if (it == doc.end()) return std::nullopt;
  if (!it->is_number_integer()) throw MalformedDocument(std::string(what) + "'s \"" + name + "\" is not a number");
  return it->get<std::int64_t>();
}

inline void want_object(const nlohmann::json& doc, const char* what) {
  if (!doc.is_object()) throw MalformedDocument(std::string(what) + " is not a JSON object");
}

}  // namespace rsd::model::read_json
