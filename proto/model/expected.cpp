// Expected cameras: parsing the configuration's form, and writing the API's document (expected.hpp).
#include "rsd_model/expected.hpp"

#include "rsd_model/spelling.hpp"

#include <algorithm>

namespace rsd::model {

namespace {


bool fail(std::string* error, std::string message) {
  if (error) *error = std::move(message);
  return false;
}

// A name: letters, digits, '-', '_' and '.', so it reads the same in a metric label,
// a log line and a shell.
bool good_name(std::string_view name, std::string* error) {
  const bool ok = !name.empty() && name.size() <= kMaxExpectedName &&
                  std::all_of(name.begin(), name.end(), [](char c) {
                    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
                           c == '_' || c == '.';
                  });
  return ok || fail(error, "a camera's name is 1-" + std::to_string(kMaxExpectedName) +
                               " letters, digits, '-', '_' or '.', not '" + std::string(name) + "'");
}

// A serial or topic-root as realdds and USB spell them: printable, no space, no '='.
bool good_key(std::string_view key, std::string* error) {
  const bool ok = !key.empty() && key.size() <= kMaxExpectedKey &&
                  std::all_of(key.begin(), key.end(), [](char c) { return c > ' ' && c < 127 && c != '='; });
  return ok || fail(error, "expected a serial number or a topic-root (realsense/D555_123456), not '" +
                               std::string(key) + "'");
}

}  // namespace

std::optional<ExpectedCamera> parse_expected(std::string_view text, std::string* error) {
  ExpectedCamera out;
  const auto eq = text.find('=');
  if (eq != std::string_view::npos) {
    if (!good_name(text.substr(0, eq), error)) return std::nullopt;
    out.name = std::string(text.substr(0, eq));
    text.remove_prefix(eq + 1);
  }
  if (!good_key(text, error)) return std::nullopt;
  (text.find('/') == std::string_view::npos ? out.serial : out.topic_root) = std::string(text);
  return out;
}

std::optional<ExpectedCamera> expected_from_json(const nlohmann::json& value, std::string* error) {
  if (value.is_string()) return parse_expected(value.get<std::string>(), error);
  const auto bad = [&] {
    fail(error, "an expected camera is \"[NAME=]SERIAL\", \"[NAME=]TOPIC-ROOT\" or an object with \"serial\" or "
                "\"topic-root\" and an optional \"name\", not " + value.dump());
    return std::nullopt;
  };
  if (!value.is_object()) return bad();
  ExpectedCamera out;
  for (const auto& [k, v] : value.items()) {
    if (!v.is_string() || (k != expected_key::name && k != expected_key::serial && k != expected_key::topic_root)) return bad();
    (k == expected_key::name ? out.name : k == expected_key::serial ? out.serial : out.topic_root) = v.get<std::string>();
  }
  if (out.serial.empty() == out.topic_root.empty()) return bad();
  if (!out.name.empty() || value.contains(expected_key::name))
    if (!good_name(out.name, error)) return std::nullopt;
  if (!good_key(out.key(), error)) return std::nullopt;
  return out;
}

std::string describe(const ExpectedCamera& camera) {
  return camera.name.empty() ? camera.key() : camera.name + " (" + camera.key() + ")";
}

namespace {

nlohmann::json to_json(const ExpectedStatus& s) {
  nlohmann::json out = nlohmann::json::object();
  if (!s.camera.name.empty()) out[expected_key::name] = s.camera.name;
  if (!s.camera.serial.empty()) out[expected_key::serial] = s.camera.serial;
  if (!s.camera.topic_root.empty()) out[expected_key::topic_root] = s.camera.topic_root;
  if (s.id) out[expected_key::id] = *s.id;
  if (s.last_seen) out[expected_key::last_seen] = *s.last_seen;
  if (s.reason) out[expected_key::reason] = *s.reason;
  return out;
}

}  // namespace

nlohmann::json to_json(const ExpectedReport& report) {
  nlohmann::json present = nlohmann::json::array(), missing = nlohmann::json::array();
  for (const auto& s : report.present) present.push_back(to_json(s));
  for (const auto& s : report.missing) missing.push_back(to_json(s));
  return {{expected_key::complete, report.complete},
          {expected_key::expected, report.expected()},
          {expected_key::present, std::move(present)},
          {expected_key::missing, std::move(missing)}};
}

}  // namespace rsd::model
