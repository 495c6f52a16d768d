// Reading the API's status documents strictly (status.cpp, participant.cpp): a
// missing or mistyped key is a MalformedDocument naming the key and the document.
// Internal to rsd_model: not installed, not part of the contract's headers.
#pragma once

#include "rsd_model/status.hpp"  // MalformedDocument

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>

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

inline void want_object(const nlohmann::json& doc, const char* what) {
  if (!doc.is_object()) throw MalformedDocument(std::string(what) + " is not a JSON object");
}

}  // namespace rsd::model::read_json
