// rs-discover doctor's look at the daemon's history (GET /v1/history): cameras that
// left (why, when, and for one lost by lease whether its host still answers) and
// cameras that flap (lost by lease and back within a minute).
#include "doctor.hpp"

#include <map>

namespace rsdiscover::doctor {

namespace {
constexpr std::size_t kMostNamed = 10;  // per kind of finding: a report, not a log

struct Seen {
  std::uint64_t flaps = 0;
  const rsdiscovery::json::Value* last = nullptr;  // the latest change
  std::string server;           // the latest removal's words, which name the server and its host
};
}  // namespace

void check_history(Report& r, const std::string& history_json) {
  using rsdiscovery::json::find;
  using rsdiscovery::json::text_or;
  const auto doc = rsdiscovery::json::parse_or_null(history_json);
  const auto* changes = find(doc, "changes");
  if (!changes || !changes->IsArray()) return;  // an older daemon
  std::map<std::string, Seen> by_id;
  for (const auto& c : changes->GetArray()) {
    if (!c.IsObject()) continue;
    Seen& s = by_id[text_or(find(c, "id"))];
    if (rsdiscovery::json::boolean(find(c, "flap")).value_or(false)) ++s.flaps;
    if (text_or(find(c, "event")) == "removed" && find(c, "detail")) s.server = text_or(find(c, "detail"));
    s.last = &c;
  }
  std::size_t gone = 0, flapping = 0;
  for (const auto& [id, s] : by_id) {
    if (s.flaps > 0 && flapping++ < kMostNamed)
      r.add(Verdict::warn, "flaps",
            id + " was lost by its lease and back within a minute " + std::to_string(s.flaps) + " time" +
                (s.flaps == 1 ? "" : "s") + (s.server.empty() ? "" : " (last: " + s.server + ")") +
                ": the link to its host loses packets, or its server stalls");
    // A camera whose server said it was stopping or closed it (its writer went with the
    // server still there, as a server that exits does), that was unplugged, or whose
    // domain the user dropped, left on purpose: worth knowing, no fault. Lost by its
    // lease, with the network, or refused: that explains a missing camera.
    const std::string reason = text_or(find(s.last, "reason"), "?");
    const bool meant = reason != "lease-expired" && reason != "interface-gone" && reason != "refused";
    // A lease-expired camera's host, probed by the daemon after the removal.
    const std::string host = text_or(find(s.last, "host-check"));
    const std::string host_words =
        host == "host-present"     ? "; its host still answers: the camera's server hung (power-cycle a PoE camera)"
        : host == "host-unreachable" ? "; its host does not answer: check the cable, the switch or the power"
                                     : "";
    if (text_or(find(s.last, "event")) == "removed" && gone++ < kMostNamed)
      r.add(meant ? Verdict::info : Verdict::warn, "gone",
            id + " left at " + text_or(find(s.last, "at")) + ": " + reason +
                (s.server.empty() ? "" : " (" + s.server + ")") + host_words + " ('rs-discover history " + id +
                "')");
  }
  if (gone > kMostNamed) r.add(Verdict::info, "gone", std::to_string(gone - kMostNamed) + " more cameras left");
  if (flapping > kMostNamed) r.add(Verdict::info, "flaps", std::to_string(flapping - kMostNamed) + " more cameras flap");
}

}  // namespace rsdiscover::doctor
