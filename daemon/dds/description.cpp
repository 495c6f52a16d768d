#include "dds/description.hpp"

#include <algorithm>

namespace rsd::dds {
namespace {

// realdds announces a handful of streams; a header claiming thousands is not a camera.
constexpr std::int64_t kMaxStreams = 64;

bool is_string(const nlohmann::json& j, const char* key) { return j.contains(key) && j[key].is_string(); }

// [fps, format, width, height] for video, [fps] for motion.
std::optional<nlohmann::json> profile_json(const nlohmann::json& p) {
  if (!p.is_array() || p.empty() || !p[0].is_number_integer()) return std::nullopt;
  nlohmann::json out = {{"fps", p[0]}};
  if (p.size() >= 2) {
    if (!p[1].is_string()) return std::nullopt;
    out["format"] = p[1];
  }
  if (p.size() >= 4) {
    if (!p[2].is_number_integer() || !p[3].is_number_integer()) return std::nullopt;
    out["width"] = p[2];
    out["height"] = p[3];
  }
  return out;
}

std::optional<nlohmann::json> options_json(const nlohmann::json& options) {
  if (!options.is_array()) return std::nullopt;
  nlohmann::json out = nlohmann::json::array();
  for (const auto& o : options) {
    if (!o.is_array() || o.empty() || !o[0].is_string()) return std::nullopt;
    out.push_back(option_json(o));
  }
  return out;
}

}  // namespace

nlohmann::json option_json(const nlohmann::json& o) {
  nlohmann::json out = {{"name", o[0]}};
  if (o.size() >= 2) out["value"] = o[1];
  const bool range = o.size() >= 7 && std::all_of(o.begin() + 2, o.begin() + 6, [](const auto& v) {
                       return v.is_number() || v.is_null();
                     });
  if (range) {
    out["min"] = o[2];
    out["max"] = o[3];
    out["step"] = o[4];
    out["default"] = o[5];
  }
  if (o.size() >= 3) {
    const auto& d = range ? o[6] : o.back();
    if (d.is_string()) out["description"] = d;
  }
  out["json"] = o;  // as the server sent it: the forms vary between option kinds
  return out;
}

std::string DescriptionAssembler::add(const nlohmann::json& m) {
  if (!m.is_object() || !is_string(m, "id")) return "";  // not a message of the set
  const std::string id = m["id"].get<std::string>();
  if (id == "device-header") {
    const auto n = m.find("n-streams");
    if (n == m.end() || !n->is_number_integer() || n->get<std::int64_t>() < 0 || n->get<std::int64_t>() > kMaxStreams)
      return "bad-device-header";
    if (m.contains("extrinsics") && !m["extrinsics"].is_array()) return "bad-device-header";
    header_ = m;
    n_streams_ = n->get<std::size_t>();
    device_options_ = nlohmann::json::array();
    streams_ = nlohmann::json::array();
    options_seen_.clear();
    device_options_seen_ = false;
    step_ = n_streams_ == 0 ? Step::complete : Step::partial;
    return "";
  }
  if (step_ != Step::partial) return "";  // the tail of a set whose header we did not see, or a repeat
  if (id == "device-options") {
    auto options = m.contains("options") ? options_json(m["options"]) : std::nullopt;
    if (!options) return "bad-device-options";
    device_options_ = std::move(*options);
    device_options_seen_ = true;
    return "";
  }
  if (id == "stream-header") {
    if (!is_string(m, "name") || !is_string(m, "type") || !is_string(m, "sensor-name") || !m.contains("profiles") ||
        !m["profiles"].is_array())
      return "bad-stream-header";
    nlohmann::json profiles = nlohmann::json::array();
    for (const auto& p : m["profiles"]) {
      auto profile = profile_json(p);
      if (!profile) return "bad-stream-header";
      profiles.push_back(std::move(*profile));
    }
    nlohmann::json stream = {{"name", m["name"]},
                             {"type", m["type"]},
                             {"sensor-name", m["sensor-name"]},
                             {"profiles", profiles},
                             {"default-profile", nullptr},
                             {"metadata-enabled", m.value("metadata-enabled", false)},
                             {"options", nlohmann::json::array()}};
    if (const auto i = m.find("default-profile-index");
        i != m.end() && i->is_number_integer() && i->get<std::int64_t>() >= 0 &&
        i->get<std::size_t>() < profiles.size())
      stream["default-profile"] = profiles[i->get<std::size_t>()];
    const auto same = std::find_if(streams_.begin(), streams_.end(),
                                   [&](const auto& s) { return s["name"] == m["name"]; });
    if (same != streams_.end()) {
      *same = std::move(stream);
      options_seen_[static_cast<std::size_t>(same - streams_.begin())] = false;
    } else {
      if (streams_.size() >= n_streams_) return "too-many-streams";
      streams_.push_back(std::move(stream));
      options_seen_.push_back(false);
    }
    return "";
  }
  if (id == "stream-options") {
    if (!is_string(m, "stream-name")) return "bad-stream-options";
    const auto it = std::find_if(streams_.begin(), streams_.end(),
                                 [&](const auto& s) { return s["name"] == m["stream-name"]; });
    if (it == streams_.end()) return "unknown-stream";
    auto options = m.contains("options") ? options_json(m["options"]) : std::nullopt;
    if (!options) return "bad-stream-options";
    (*it)["options"] = std::move(*options);
    if (m.contains("intrinsics")) (*it)["intrinsics"] = m["intrinsics"];
    if (m.contains("embedded-filters")) (*it)["embedded-filters"] = m["embedded-filters"];
    options_seen_[static_cast<std::size_t>(it - streams_.begin())] = true;
    if (streams_.size() == n_streams_ && std::all_of(options_seen_.begin(), options_seen_.end(), [](bool b) { return b; }))
      step_ = Step::complete;
    return "";
  }
  return "";  // another kind of notification
}

std::string DescriptionAssembler::stage() const {
  if (step_ == Step::complete) return "complete";
  if (step_ == Step::waiting) return "no device-header";
  if (streams_.empty()) return device_options_seen_ ? "device-options" : "device-header";
  const auto done = std::count(options_seen_.begin(), options_seen_.end(), true);
  return "stream " + std::to_string(done) + " of " + std::to_string(n_streams_);
}

nlohmann::json DescriptionAssembler::description() const {
  nlohmann::json extrinsics = nlohmann::json::array();
  if (header_.contains("extrinsics"))
    for (const auto& e : header_["extrinsics"]) {
      // [from, to, [r0..r8, t0..t2]]: rotation (column-major, as librealsense) and translation in metres
      if (!e.is_array() || e.size() != 3 || !e[0].is_string() || !e[1].is_string() || !e[2].is_array() ||
          e[2].size() != 12)
        continue;
      nlohmann::json rotation = nlohmann::json::array(), translation = nlohmann::json::array();
      for (std::size_t i = 0; i < 9; ++i) rotation.push_back(e[2][i]);
      for (std::size_t i = 9; i < 12; ++i) translation.push_back(e[2][i]);
      extrinsics.push_back({{"from", e[0]}, {"to", e[1]}, {"rotation", rotation}, {"translation", translation}});
    }
  nlohmann::json presets = header_.contains("presets") && header_["presets"].is_array() ? header_["presets"]
                                                                                        : nlohmann::json::array();
  return {{"streams", streams_},
          {"device-options", device_options_},
          {"extrinsics", extrinsics},
          {"presets", presets}};
}

}  // namespace rsd::dds
