// rs-discover doctor's word on USB sharing (docs/sharing.md): which hosts' daemons share
// their USB cameras with this one (the remote-usb cameras it lists, by host), and
// which other daemons it hears share none.
#include "doctor.hpp"

#include <map>
#include <set>

namespace rsdiscover::doctor {

void check_sharing(Report& r, const std::vector<rsdiscovery::Device>& devices,
                   const std::vector<rsdiscovery::Participant>& participants,
                   const std::vector<rsdiscovery::DomainStatus>& domains) {
  struct Sharer {
    std::vector<std::string> addresses;
    std::size_t cameras = 0;
    std::set<int> domains;
  };
  std::map<std::string, Sharer> sharers;  // by host name, as the sharer announces it
  for (const auto& d : devices) {
    const auto host = rsdiscovery::sharing_host(d);
    if (!host) continue;
    auto& s = sharers[host->name];
    ++s.cameras;
    if (d.domain) s.domains.insert(*d.domain);
    if (s.addresses.empty()) s.addresses = host->addresses;
  }
  for (const auto& [name, s] : sharers) {
    std::vector<std::string> ds;
    for (int d : s.domains) ds.push_back(std::to_string(d));
    r.add(Verdict::ok, "sharing",
          "host '" + (name.empty() ? std::string("(unnamed)") : name) + "'" +
              (s.addresses.empty() ? "" : " at " + join(s.addresses, ", ")) + " shares " + std::to_string(s.cameras) +
              " USB camera" + (s.cameras == 1 ? "" : "s") + (ds.empty() ? "" : " (domain " + join(ds, ", ") + ")"));
  }
  // Other daemons heard on the domains: a host whose cameras are missing here may
  // run without share-usb. Said as what is seen, not as a fault: sharing is opt-in.
  std::set<std::string> own;
  for (const auto& d : domains) own.insert(d.participant_guid);
  std::set<std::string> quiet;
  for (const auto& p : participants)
    if (p.process == "rs-discoveryd" && p.state == "alive" && !own.contains(p.guid) && !p.host.empty() &&
        !sharers.contains(p.host))
      quiet.insert(p.host);
  for (const auto& host : quiet)
    r.add(Verdict::info, "sharing",
          "rs-discoveryd on '" + host + "' shares no USB camera with this one (it runs without share-usb, or has "
          "none plugged)");
}

}  // namespace rsdiscover::doctor
