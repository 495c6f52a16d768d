// rs-discover domains: the daemon's DDS domains and what each has seen.
#include "common.hpp"

namespace rsdiscover {
namespace {

int run(const ParsedArgs& args) {
  if (!args.positional.empty()) throw UsageError("unexpected argument '" + args.positional[0] + "'");
  auto client = make_client(args);
  auto domains = client.domains();
  if (args.has("json")) {
    std::string out = "{\"domains\":[";
    for (std::size_t i = 0; i < domains.size(); ++i) out += (i ? "," : "") + domains[i].json;
    std::fputs((out + "]}\n").c_str(), stdout);
    return kOk;
  }
  Table table({"DOMAIN", "STATE", "DEVICES", "ACCEPTED", "REJECTED", "PARTICIPANT"});
  for (const auto& d : domains) {
    std::uint64_t rejected = 0;
    std::vector<std::string> reasons;
    for (const auto& [reason, n] : d.rejected) {
      rejected += n;
      if (n) reasons.push_back(reason + " " + std::to_string(n));
    }
    std::string rej = std::to_string(rejected);
    if (!reasons.empty()) rej += " (" + join(reasons, ", ") + ")";
    const char* state_col = d.state == "running" ? color::green : d.state == "failed" ? color::red : color::yellow;
    table.add({std::to_string(d.domain), d.state.empty() ? "-" : d.state, std::to_string(d.devices),
               std::to_string(d.accepted), rej, d.participant_guid.empty() ? "-" : d.participant_guid},
              {nullptr, state_col, nullptr, nullptr, rejected ? color::yellow : nullptr, nullptr});
  }
  table.print(stdout);
  return kOk;
}

}  // namespace

const Command kDomainsCommand = {
    "domains",
    "show the DDS domains the daemon watches",
    "domains [--json]",
    "Show each DDS domain the daemon watches: its state, how many devices it has, how many\n"
    "device-info messages it took and rejected (by reason), and the daemon's participant.",
    {
        {"json", 'j', nullptr, "print JSON as the API gives it: {\"domains\": [...]}"},
        kNoHeadersOption,
    },
    run,
};

}  // namespace rsdiscover
