// What a camera can do, from the messages its realdds server sends on
// <topic-root>/notification when a client subscribes (Camera Discovery use case):
// device-header, optional device-options, then per stream a stream-header and
// its stream-options. Pure: DescriptionFetcher feeds it, tests replay messages
// captured from a real realdds server.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace rsd::dds {

class DescriptionAssembler {
 public:
  enum class Step {
    waiting,   // nothing of this set yet (or only messages of other kinds)
    partial,   // a device-header came, streams are still missing
    complete,  // every stream's header and options came: description() is ready
  };

  // One notification message (the JSON object as sent). Messages of other
  // kinds (the server's replies, option changes...) are ignored; a second
  // device-header starts the set over, since the server sends a whole new set
  // when another client subscribes. Returns a reject reason for a malformed
  // message of the set ("" when it was taken or ignored).
  std::string add(const nlohmann::json& message);

  Step step() const { return step_; }
  // How far the set got, for a camera that never completes it: "no device-header",
  // "device-header", "device-options" (then no stream yet), "stream K of N" (K
  // streams with both their header and their options), or "complete".
  std::string stage() const;
  // The description, once complete: streams (name, type, sensor, profiles,
  // default profile, metadata, options, intrinsics), device options,
  // extrinsics, presets. See proto/openapi.yaml, DeviceDescription.
  nlohmann::json description() const;

 private:
  Step step_ = Step::waiting;
  std::size_t n_streams_ = 0;
  nlohmann::json header_;          // device-header
  nlohmann::json device_options_ = nlohmann::json::array();
  nlohmann::json streams_ = nlohmann::json::array();  // in the order their headers came
  std::vector<bool> options_seen_;                    // per stream: its stream-options came
  bool device_options_seen_ = false;
};

// A realdds option as JSON ([name, value, min, max, step, default, description,
// ...] for a range; shorter forms for others) as an object a user can read.
nlohmann::json option_json(const nlohmann::json& option);

}  // namespace rsd::dds
