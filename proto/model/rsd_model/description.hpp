// A camera's description (GET /v1/devices/{id}/description; proto/openapi.yaml
// `DeviceDescription`) as a type: its streams with their profiles and options, its
// device options, extrinsics and presets. The daemon's answer goes through
// to_json(description_from_json(...)), so what it serves is what this type holds.
#pragma once

#include "rsd_model/status.hpp"  // MalformedDocument

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace rsd::model {

// One way a stream can run. Motion streams have a rate only.
struct Profile {
  int fps = 0;
  std::optional<std::string> format;  // realdds' encoding name, e.g. "16UC1", "rgb8"
  std::optional<int> width, height;
};

// A realdds option. Its array form varies between option kinds, so `json` keeps it
// as the server sent it; the common members are picked out when present.
struct Option {
  std::string name;
  nlohmann::json value, min, max, step, default_value;  // null when absent
  std::optional<std::string> description;
  nlohmann::json json;  // the server's own form
};

struct Stream {
  std::string name;
  std::string type;         // depth, color, ir, motion, ...
  std::string sensor_name;  // e.g. "Stereo Module"
  std::vector<Profile> profiles;
  std::optional<Profile> default_profile;
  bool metadata_enabled = false;
  std::vector<Option> options;
  std::optional<nlohmann::json> intrinsics;        // verbatim
  std::optional<nlohmann::json> embedded_filters;  // verbatim
};

struct Extrinsics {
  std::string from, to;
  std::vector<double> rotation;     // 9, row-major
  std::vector<double> translation;  // 3
};

struct Description {
  std::vector<Stream> streams;
  std::vector<Option> device_options;
  std::vector<Extrinsics> extrinsics;
  std::vector<nlohmann::json> presets;
};

nlohmann::json to_json(const Description& description);
Description description_from_json(const nlohmann::json& doc);  // throws MalformedDocument

}  // namespace rsd::model
