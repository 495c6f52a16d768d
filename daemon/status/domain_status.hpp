// What a DDS domain reports about itself, for /v1/domains, /healthz, /metrics and
// STATUS=. A plain value in a folder of its own: the DDS source fills it, the
// service and the API read it, and neither side includes the other's headers.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace rsd {

// A domain's life: settling (participant made, reader not yet created) ->
// running; rebuilding while its participant is made anew; failed when it cannot
// be joined; stopped once left. The API shows to_string() of it.
enum class DomainState { settling, running, rebuilding, failed, stopped };

constexpr std::string_view to_string(DomainState state) {
  switch (state) {
    case DomainState::settling: return "settling";
    case DomainState::running: return "running";
    case DomainState::rebuilding: return "rebuilding";
    case DomainState::failed: return "failed";
    case DomainState::stopped: return "stopped";
  }
  return "stopped";  // not reached: every enumerator is named above
}

constexpr std::optional<DomainState> parse_domain_state(std::string_view name) {
  for (auto s : {DomainState::settling, DomainState::running, DomainState::rebuilding, DomainState::failed,
                 DomainState::stopped})
    if (to_string(s) == name) return s;
  return std::nullopt;
}

struct DomainStatus {
  int domain = 0;
  DomainState state = DomainState::stopped;
  std::string participant_guid;  // ours, "" until the participant exists
  std::string error;             // why the domain is failed, else ""
  std::size_t devices = 0;       // devices of this domain now in the table
  std::uint64_t accepted = 0;    // device-info messages taken into the table
  std::uint64_t stopping = 0;    // 'stopping' messages honoured
  std::map<std::string, std::uint64_t> rejected;  // reason -> count
  std::uint64_t rebuilds = 0;    // times the participant was torn down and made anew
  std::uint64_t refreshes = 0;   // of those, made anew by itself to find a lost server again
  std::size_t lost_servers = 0;  // servers lost without 'stopping', still looked for
  // The domain's first discovery is over: its reader has existed long enough for
  // every server already on the network to have announced its devices (or the
  // domain failed, so nothing more will come). Until then a device list is partial.
  bool complete = false;
};

}  // namespace rsd
