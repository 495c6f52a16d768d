// Why a camera left the table: the one spelling of every removal reason, shared by
// the sources (which give it), the table (which keeps it in its history and gone
// entries), the API (events, history, metrics) and the clients.
#pragma once

#include <array>
#include <optional>
#include <string_view>

namespace rsd::model {

// stopping: the server said so. writer-gone: its device-info writer went while its
// participant stayed. lease-expired: its participant went silent (a crash, a hang,
// a cut). unplugged: USB. interface-gone: the daemon left the network it was on.
// domain-left: a reload dropped its domain. refused: a reload lowered a device cap
// below what was listed.
enum class RemovalReason { stopping, writer_gone, lease_expired, unplugged, interface_gone, domain_left, refused };

inline constexpr std::array<RemovalReason, 7> kRemovalReasons{
    RemovalReason::stopping,       RemovalReason::writer_gone, RemovalReason::lease_expired,
    RemovalReason::unplugged,      RemovalReason::interface_gone, RemovalReason::domain_left,
    RemovalReason::refused};

constexpr std::string_view to_string(RemovalReason reason) {
  switch (reason) {
    case RemovalReason::stopping: return "stopping";
    case RemovalReason::writer_gone: return "writer-gone";
    case RemovalReason::lease_expired: return "lease-expired";
    case RemovalReason::unplugged: return "unplugged";
    case RemovalReason::interface_gone: return "interface-gone";
    case RemovalReason::domain_left: return "domain-left";
    case RemovalReason::refused: return "refused";
  }
  return "refused";  // not reached: every enumerator is named above
}

constexpr std::optional<RemovalReason> parse_removal_reason(std::string_view name) {
  for (RemovalReason r : kRemovalReasons)
    if (to_string(r) == name) return r;
  return std::nullopt;
}

// A camera lost by its lease (no 'stopping'): is its host still on the network?
// host-present: its kernel still answers (ARP, ICMP), so DDS alone is silent, the
// camera's server hung (a PoE camera: power-cycle it). host-unreachable: nothing
// answers, so check the cable, the switch or the power.
enum class HostVerdict { present, unreachable };

inline constexpr std::array<HostVerdict, 2> kHostVerdicts{HostVerdict::present, HostVerdict::unreachable};

constexpr std::string_view to_string(HostVerdict verdict) {
  return verdict == HostVerdict::present ? "host-present" : "host-unreachable";
}

// What the event stream adds to the document of a `removed` event (reason) and of
// an `added` one (arrival: new or back; away-since: when a camera back was removed).
// The table keeps sources from setting them, so an event never carries one twice.
namespace key {
inline constexpr const char* reason = "reason";
inline constexpr const char* arrival = "arrival";
inline constexpr const char* away_since = "away-since";
// The history documents (GET /v1/devices/{id}/history, /v1/history) and a gone
// camera's answer (410 on GET /v1/devices/{id}).
inline constexpr const char* generation = "generation";
inline constexpr const char* at = "at";
inline constexpr const char* event = "event";
inline constexpr const char* detail = "detail";
inline constexpr const char* state = "state";
inline constexpr const char* changes = "changes";
inline constexpr const char* removals = "removals";
inline constexpr const char* gone = "gone";
inline constexpr const char* removed_at = "removed-at";
inline constexpr const char* device = "device";
inline constexpr const char* next = "next";
inline constexpr const char* flap = "flap";
inline constexpr const char* flaps = "flaps";
inline constexpr const char* host_check = "host-check";  // a HostVerdict, on a lease-expired removal once judged
}  // namespace key
inline constexpr const char* kArrivalNew = "new";
inline constexpr const char* kArrivalBack = "back";
inline constexpr const char* kStatePresent = "present";
inline constexpr const char* kStateGone = "gone";

}  // namespace rsd::model
