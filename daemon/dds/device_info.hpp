// realdds device-info messages: from the bytes of a `flexible` sample to either a
// device, a 'stopping' notice, or a reject reason. Pure: no DDS here, so every
// kind of bad input is unit-tested and fuzzed without a network.
#pragma once

#include "status/reasons.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <span>
#include <string>
#include <variant>

namespace rsd::dds {

// Values of realdds::topics::raw::flexible_data_format on the wire.
enum class DataFormat : std::int32_t { json = 0, cbor = 1, custom = 2 };

// Bounds on what a device-info may be. A real one is a few hundred bytes and flat.
inline constexpr std::size_t kMaxPayload = 4095;  // realdds' sequence bound is 4096
inline constexpr int kMaxDepth = 16;

struct DeviceInfo {
  nlohmann::json fields;  // the message verbatim (an object with string name/topic-root)
  std::string topic_root;
};

struct Stopping {
  std::string topic_root;
};

struct Rejected {
  std::string reason;  // short, stable, used as a metrics label (see kRejectReasons)
  std::string detail;  // for the log
};

using Parsed = std::variant<DeviceInfo, Stopping, Rejected>;

// The reasons parse_device_info() may give, for documentation and metrics: one list,
// which the API reads too (status/reasons.hpp).
inline constexpr const auto& kRejectReasons = kParseRejectReasons;

Parsed parse_device_info(std::int32_t format, std::span<const std::uint8_t> data);

// The document in a `flexible` sample (JSON or CBOR), with the same bounds and
// checks (size, depth, UTF-8) but no expectation of its shape: for the other
// realdds topics (notification). The reject reasons are the first ones above.
std::variant<nlohmann::json, Rejected> parse_flexible(std::int32_t format, std::span<const std::uint8_t> data);

// True when `text` is well-formed UTF-8 (no overlongs, surrogates or code points
// past U+10FFFF): what nlohmann needs to serialise it later without throwing.
bool is_valid_utf8(std::string_view text);

// The device's id in the API: stable across restarts, unique per (domain,
// topic-root), and URL-safe. '/' becomes '.', bytes outside [A-Za-z0-9_-] become
// "~XX", so the mapping can be inverted and two topic-roots never share an id.
std::string device_id(int domain, const std::string& topic_root);

}  // namespace rsd::dds
