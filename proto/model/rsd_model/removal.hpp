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
// domain-left: a reload dropped its domain. refused: a cap refused it.
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

}  // namespace rsd::model
