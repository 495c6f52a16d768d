// Camera Discovery's answer for one device (GET /v1/devices/{id}/description): the
// DDS source gives it, the API serialises it. A plain value, beside the sources'
// other status values, so the API needs no DDS header to show it.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace rsd {

struct DeviceDescription {
  enum class Outcome {
    ok,           // `description` holds the streams, options, extrinsics, presets
    not_found,    // no such device (or it left meanwhile)
    not_network,  // a USB-only camera: nothing describes it without opening it
    recovery,     // running its recovery firmware: no streams
    timeout,      // its server sent no whole set in time
    unavailable,  // the domain is starting or being made anew: ask again soon
  };
  Outcome outcome = Outcome::not_found;
  nlohmann::json description;
  std::string error;  // for the user, when not ok
};

}  // namespace rsd
