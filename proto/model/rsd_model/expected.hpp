// Expected cameras: the ones a robot, a cell or a rig is built with, as the daemon's
// configuration names them (`expect`, --expect), and the API's document of which of
// them are listed now (GET /v1/expected, /healthz "expected"; proto/openapi.yaml
// `Expected`). The daemon writes it with the keys of spelling.hpp, which the clients read it by.
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::model {

// A camera named by its serial or its topic-root (exactly one of the two is set),
// with an optional name of the user's ("front", "wrist").
struct ExpectedCamera {
  std::string name;  // "" when unnamed
  std::string serial;
  std::string topic_root;
  // The serial or the topic-root: what names the camera (Device::named_by).
  const std::string& key() const { return serial.empty() ? topic_root : serial; }
  bool operator==(const ExpectedCamera&) const = default;
};

// At most this many expected cameras, names and keys this long: a rig's list, bounded.
inline constexpr std::size_t kMaxExpected = 256;
inline constexpr std::size_t kMaxExpectedName = 64;
inline constexpr std::size_t kMaxExpectedKey = 256;

// "[NAME=]SERIAL" or "[NAME=]TOPIC-ROOT" (a topic-root has a '/': realsense/D555_123).
// Nothing, and `error` says why, for anything else.
std::optional<ExpectedCamera> parse_expected(std::string_view text, std::string* error);
// The file's form: that text, or {"serial": S, "name": N} / {"topic-root": T, "name": N}.
std::optional<ExpectedCamera> expected_from_json(const nlohmann::json& value, std::string* error);
// How messages name it: "front (123456)", or the key alone when unnamed.
std::string describe(const ExpectedCamera& camera);

// One expected camera as the daemon sees it now.
struct ExpectedStatus {
  ExpectedCamera camera;
  std::optional<std::string> id;         // present: the table's entry that is it
  std::optional<std::string> last_seen;  // missing: when the daemon last listed it
  std::optional<std::string> reason;     // missing: why it left the table
};

struct ExpectedReport {
  // Every domain's first discovery is over: a camera missing now is not merely unheard yet.
  bool complete = false;
  std::vector<ExpectedStatus> present;
  std::vector<ExpectedStatus> missing;  // in the configuration's order, as `present`
  std::size_t expected() const { return present.size() + missing.size(); }
};

nlohmann::json to_json(const ExpectedReport& report);

}  // namespace rsd::model
