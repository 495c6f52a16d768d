// The USB cameras daemons share with one another (proto/shared_usb.idl):
// what a sharing daemon writes for one of its local cameras, and what a reader
// makes of another host's sample. Pure, like device_info: every kind of bad input
// is unit-tested and fuzzed without a network.
#pragma once

#include "dds/device_info.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace rsd::dds {

inline constexpr const char* kSharedUsbTopic = "rs-discoveryd/shared-usb";
inline constexpr std::uint8_t kSharedUsbVersion = 1;
// The IDL's bounds (string<64>, string<96>); a host lists a few addresses, a
// camera a few warnings.
inline constexpr std::size_t kMaxHostKey = 64;
inline constexpr std::size_t kMaxCameraKey = 96;
inline constexpr std::size_t kMaxSharedAddresses = 16;
inline constexpr std::size_t kMaxSharedWarnings = 8;
inline constexpr std::size_t kMaxSharedText = 512;  // any one string of the device

// Another host's camera, as the table will hold it.
struct SharedCamera {
  std::string id;         // "<camera>.<host>": the table's id, unique per host and camera
  nlohmann::json device;  // source "remote-usb", the camera's fields, "host", "domain"
};

// What a sharer writes for its local camera `local` (the USB source's document):
// the JSON of the sample's `data`.
std::string shared_usb_payload(const std::string& host_name, const std::vector<std::string>& addresses,
                               const nlohmann::json& local);

// A sample of the topic, from any peer: `host` and `camera` are its key fields,
// `participant_guid` its writer's participant. Reasons are "shared-*" (the first
// ones parse_flexible's, prefixed), listed in status/reasons.hpp.
std::variant<SharedCamera, Rejected> parse_shared_usb(int domain, std::string_view host, std::string_view camera,
                                                      std::uint8_t version, std::span<const std::uint8_t> data,
                                                      const std::string& participant_guid);

// "<camera>.<host>" (usb-123622270732.rig-pc-3), the host's bytes outside
// [A-Za-z0-9_-] as "~XX": two hosts never share an id, the id stays URL-safe (the
// API's id pattern), and its last '.' starts the host.
std::string shared_usb_id(std::string_view host, std::string_view camera);

}  // namespace rsd::dds
