// rs-discover doctor's checks: what the daemon says (its domains, the participants it
// hears, its cameras, USB, HTTP), what this host hears on every domain's discovery
// port (spdp.hpp) and this host's network, each turned into findings that say what to
// do, one line each.
#include "doctor.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <map>
#include <set>

namespace rsdiscover::doctor {
namespace {

using rsdiscovery::json::find;
using rsdiscovery::json::text_or;

// The UDP ports of DDS domain d (the RTPS port mapping): 7400 + 250 d upwards. The
// daemon's Cyclone DDS receives unicast on a port of its own choosing besides
// (measured: dropping the domain's range on the daemon's host left discovery
// working through it), so a firewall is best opened by address.
std::string ports_of(int domain) {
  const int base = 7400 + 250 * domain;
  return "UDP " + std::to_string(base) + "-" + std::to_string(base + 249) + " (domain " + std::to_string(domain) +
         "; Cyclone DDS adds a port of its choosing unless ParticipantIndex is set)";
}

double seconds_between(const std::string& from, const std::string& to) {
  const auto a = parse_iso8601(from), b = parse_iso8601(to);
  return a && b ? *b - *a : 0;
}

std::string who(const rsdiscovery::Participant& p) {
  std::string name = p.name.empty() ? p.guid : "'" + p.name + "'";
  if (!p.addresses.empty()) name += " at " + join(p.addresses, ", ");
  return name + " (domain " + std::to_string(p.domain) + ")";
}

}  // namespace

// Who announces itself on a domain the daemon does not join: the likeliest reason a
// camera is missing. Heard here for a few seconds (spdp.hpp); a Fast DDS participant
// may be a realdds camera server (librealsense programs run on Fast DDS too, and
// which topics a participant writes is not in its announcement), so it is a `warn`;
// other implementations (ROS 2 on Cyclone, other tools) only `info`.
void check_other_domains(Report& r, const std::vector<rsdiscovery::DomainStatus>& domains,
                         const std::optional<spdp::Heard>& heard, double listened_s) {
  std::set<int> mine;
  for (const auto& d : domains) mine.insert(d.domain);
  std::vector<std::string> joined;
  for (int d : mine) joined.push_back(std::to_string(d));
  const std::string ours = (mine.size() == 1 ? "the daemon listens on " : "the daemon listens on domains ") +
                           join(joined, ", ");
  if (!heard) return;
  char secs[16];
  std::snprintf(secs, sizeof secs, "%g", listened_s);
  if (heard->listened.empty()) {
    r.add(Verdict::info, "domains", "could not listen on any domain's discovery port here (UDP 7400 + 250 d is "
                                    "taken): other domains are not checked");
    return;
  }
  std::map<int, std::vector<const spdp::Announcement*>> others;
  for (const auto& a : heard->participants)
    if (!mine.count(a.domain)) others[a.domain].push_back(&a);
  if (others.empty()) {
    r.add(Verdict::ok, "domains", "nothing else announces itself here on any of the " +
                                      std::to_string(heard->listened.size()) + " domains' discovery ports (listened " +
                                      secs + " s)");
    return;
  }
  for (const auto& [domain, who_there] : others) {
    bool fast_dds = false;
    std::vector<std::string> names;
    for (const auto* a : who_there) {
      fast_dds = fast_dds || a->vendor_id == "01.0f";
      if (names.size() == 4) {
        names.push_back("and " + std::to_string(who_there.size() - 4) + " more");
        break;
      }
      std::string n = a->name.empty() ? a->guid_prefix : "'" + a->name + "'";
      if (!a->addresses.empty()) n += " at " + join(a->addresses, ", ");
      n += " (" + std::string(a->vendor_id == "01.0f" ? "Fast DDS" : a->vendor_id == "01.10" ? "Cyclone DDS"
                                                                                            : "vendor " + a->vendor_id) +
           ")";
      names.push_back(n);
    }
    const std::string d = std::to_string(domain);
    const std::string count = who_there.size() == 1 ? "announces itself" : "announce themselves";
    if (fast_dds)
      r.add(Verdict::warn, "domains",
            "on domain " + d + " " + join(names, ", ") + " " + count + "; " + ours +
                ". realdds camera servers (and librealsense) run on Fast DDS: if the missing camera is there, add "
                "--domain " + d + " (\"domains\" in the config) or set the camera to the daemon's domain");
    else
      r.add(Verdict::info, "domains", "on domain " + d + " " + join(names, ", ") + " " + count + "; " + ours +
                                          " (not Fast DDS, so not a realdds camera server)");
  }
}

void check_domains(Report& r, const std::vector<rsdiscovery::DomainStatus>& domains) {
  std::vector<std::string> joined;
  bool zero = false;
  for (const auto& d : domains) {
    joined.push_back(std::to_string(d.domain) + " (" + d.state + ")");
    zero = zero || d.domain == 0;
    if (d.state == "failed") {
      const std::string why = text_or(find(rsdiscovery::json::parse_or_null(d.json), "error"));
      r.add(Verdict::fail, "domain", "domain " + std::to_string(d.domain) + " could not be joined: " + why);
    }
  }
  r.add(Verdict::ok, "domains", "the daemon listens on DDS domain" + std::string(domains.size() == 1 ? " " : "s ") +
                                    join(joined, ", "));
  if (!zero)
    r.add(Verdict::info, "domains", "domain 0 is not among them: cameras and librealsense use domain 0 unless "
                                    "configured otherwise (add it with --domain 0, or \"domains\" in the config)");
}

void check_participants(Report& r, const std::vector<rsdiscovery::Participant>& all,
                        const std::vector<rsdiscovery::DomainStatus>& domains) {
  std::size_t alive = 0, servers = 0;
  for (const auto& p : all) {
    if (p.state != "alive") continue;
    ++alive;
    if (p.device_info_writers > 0) ++servers;
    const double age = seconds_between(p.first_seen, p.last_seen);
    // realdds and librealsense (Fast DDS) always have readers and writers; another
    // program may have none (a bare participant, measured with Cyclone 11), so
    // for those it is only a hint.
    if (p.endpoints == 0 && age >= 5 && p.vendor == "fast-dds")
      r.add(Verdict::fail, "firewall",
            who(p) + " is heard (multicast) but has exchanged nothing with the daemon for " +
                std::to_string(static_cast<int>(age)) + " s: unicast UDP between this host and it is blocked; open " +
                ports_of(p.domain) + " both ways on both hosts");
    else if (p.endpoints == 0 && age >= 5)
      r.add(Verdict::info, "firewall",
            who(p) + " shows no readers or writers: a participant without any, or unicast UDP to it is blocked (" +
                ports_of(p.domain) + ")");
    if (p.never_announced)
      r.add(Verdict::fail, "firewall",
            who(p) + " is a realdds server whose cameras matched but never arrived: its device-info does not "
                     "get through (a firewall or an MTU problem on the path), or the server is stuck");
  }
  // Gone having exchanged nothing, within about its lease of being heard: its first
  // announcement got through and nothing after. A program that ran briefly and ended
  // (librealsense's query_devices(), a camera server stopped) exchanged its endpoints
  // first: the daemon keeps the most it had (`endpoints` of a gone participant).
  for (const auto& p : all) {
    if (p.state != "gone" || p.endpoints != 0 || p.vendor != "fast-dds") continue;
    const double life = seconds_between(p.first_seen, p.last_seen);
    if (p.lease_seconds && life <= *p.lease_seconds + 2)
      r.add(Verdict::warn, "firewall",
            who(p) + " was heard once and lost after its lease (" + std::to_string(static_cast<int>(life)) +
                " s) without exchanging anything: if it still runs, its packets stop reaching this host "
                "(a firewall letting only the first ones through; open " + ports_of(p.domain) + ")");
  }
  std::vector<int> ids;
  for (const auto& d : domains) ids.push_back(d.domain);
  if (alive == 0) {
    std::vector<std::string> names;
    for (int d : ids) names.push_back(std::to_string(d));
    std::vector<std::string> ports;
    for (int d : ids) ports.push_back(ports_of(d));
    r.add(Verdict::warn, "network",
          "nobody else is heard on domain" + std::string(ids.size() == 1 ? " " : "s ") + join(names, ", ") +
              ": the cameras are on another domain, a firewall drops " + join(ports, ", ") +
              ", or multicast discovery does not reach this host (see the multicast and interface lines)");
  } else {
    r.add(Verdict::ok, "network", std::to_string(alive) + " participant" + (alive == 1 ? "" : "s") + " heard, " +
                                      std::to_string(servers) + " announcing cameras ('rs-discover participants')");
  }
  // One topic-root from two servers: two cameras configured alike, or one camera
  // served twice; clients see either.
  std::map<std::string, std::vector<const rsdiscovery::Participant*>> by_root;
  for (const auto& p : all)
    if (p.state == "alive")
      for (const auto& root : p.topic_roots) by_root[std::to_string(p.domain) + "/" + root].push_back(&p);
  for (const auto& [key, servers_of] : by_root) {
    if (servers_of.size() < 2) continue;
    std::vector<std::string> names;
    for (const auto* p : servers_of) names.push_back(who(*p));
    r.add(Verdict::fail, "topic-root",
          key.substr(key.find('/') + 1) + " is announced by " + std::to_string(servers_of.size()) +
              " servers: " + join(names, " and ") + "; give each camera its own topic-root (its serial)");
  }
  // Addresses no one on this network can reach: a `warn` when the participant has
  // no other (its cameras are out of reach), `info` beside a routable one.
  for (const auto& p : all) {
    if (p.state != "alive") continue;
    std::vector<std::string> unreachable;
    bool routable = false;
    std::string why;
    for (const auto& a : p.addresses) {
      const auto v4 = ipv4(a);
      if (!v4) continue;
      if (link_local(*v4)) {
        unreachable.push_back(a);
        why = "has a link-local address (" + a + "): it got no address from DHCP; give it a static address or a "
              "DHCP server on its network";
      } else if (container_bridge(*v4)) {
        unreachable.push_back(a);
        why = "is on a container bridge (" + a + "): run its container with --network host, or list its address "
              "as a unicast peer in cyclonedds-config";
      } else if (v4->s_addr != 0 && (ntohl(v4->s_addr) >> 24) != 127) {
        routable = true;
      }
    }
    if (unreachable.empty()) continue;
    if (routable)
      r.add(Verdict::info, "addresses", who(p) + " " + why + " (it is reached by its other address)");
    else
      r.add(Verdict::warn, "addresses", who(p) + " " + why);
  }
}

void check_host_network(Report& r, const std::vector<rsdiscovery::Participant>& all) {
  const auto interfaces = ipv4_interfaces();
  std::vector<const Interface*> usable;
  for (const auto& i : interfaces)
    if (i.up && !i.loopback) usable.push_back(&i);
  if (usable.empty()) {
    r.add(Verdict::fail, "interface", "this host has no network interface up but loopback: only cameras on this "
                                      "host can be found");
    return;
  }
  const std::string route = multicast_route();
  if (route.empty())
    r.add(Verdict::warn, "multicast",
          "no route for multicast 239.255.0.1 (no default route, no 224.0.0.0/4 route): discovery cannot leave this "
          "host; add one ('ip route add 224.0.0.0/4 dev " + usable.front()->name +
              "'), or list the cameras as unicast peers in cyclonedds-config");
  else
    r.add(Verdict::ok, "multicast", "discovery multicast (239.255.0.1) leaves by " + route);
  // An interface without multicast (a VPN's tun0) explains nothing by itself: only a
  // camera behind it would be missed.
  for (const auto* i : usable)
    if (!i->multicast)
      r.add(Verdict::info, "multicast", i->name + " (" + text_of(i->address) +
                                            ") does not do multicast: cameras behind it need unicast peers");
  // Participants none of whose addresses is on the network discovery multicast
  // leaves by, counted per participant (a server on two networks, or a host with
  // docker0, announces every address: on the route's network too, it is fine),
  // by the interface whose network they are on. They are heard, so this explains
  // no missing camera by itself: `info`.
  const Interface* route_itf = nullptr;
  for (const auto* i : usable)
    if (i->name == route) route_itf = i;
  if (!route_itf) return;
  std::map<std::string, std::size_t> elsewhere;  // interface name -> participants only on its network
  for (const auto& p : all) {
    if (p.state != "alive") continue;
    bool on_route = false;
    std::set<std::string> on;
    for (const auto& a : p.addresses)
      if (const auto v4 = ipv4(a)) {
        if (same_subnet(*route_itf, *v4)) on_route = true;
        for (const auto* i : usable)
          if (i != route_itf && same_subnet(*i, *v4)) on.insert(i->name);
      }
    if (!on_route)
      for (const auto& name : on) ++elsewhere[name];
  }
  for (const auto& [name, n] : elsewhere)
    r.add(Verdict::info, "interface",
          std::to_string(n) + " participant" + (n == 1 ? " is" : "s are") + " on " + name +
              "'s network only, but discovery multicast leaves by " + route +
              ": if cameras there are missing, set NetworkInterface " + name + " in cyclonedds-config");
}

// The networks the daemon's domains are on (/v1/domains "interfaces", which it
// follows as the host's network changes): loopback only means the host had no
// usable interface (up, carrier, multicast, IPv4) when the daemon last looked; a
// participant heard on a domain of the daemon's from a network of this host that
// the daemon left out (--interface, exclude-interfaces) is one it cannot reach.
void check_networks(Report& r, const std::vector<rsdiscovery::DomainStatus>& domains,
                    const std::optional<spdp::Heard>& heard) {
  const auto host = ipv4_interfaces();
  for (const auto& d : domains) {
    const auto doc = rsdiscovery::json::parse_or_null(d.json);
    const auto* interfaces = find(doc, "interfaces");
    if (!interfaces || !interfaces->IsArray()) continue;
    std::set<std::string> joined;
    for (const auto& i : interfaces->GetArray())
      if (const std::string name = text_or(find(i, "name")); !name.empty()) joined.insert(name);
    if (joined.empty()) continue;  // the Cyclone DDS configuration names them: the user's choice
    const std::string dom = "domain " + std::to_string(d.domain);
    const bool loopback_only = std::all_of(joined.begin(), joined.end(), [&](const std::string& name) {
      return std::any_of(host.begin(), host.end(), [&](const Interface& i) { return i.name == name && i.loopback; });
    });
    if (loopback_only) {
      r.add(Verdict::warn, "network",
            dom + " is on loopback only: the host has no usable network interface yet (up, with carrier, "
                  "multicast and an IPv4 address; or none that --interface names). The daemon joins one as soon as "
                  "it appears; until then only cameras on this host are found");
    }
    if (!heard) continue;
    std::map<std::string, std::vector<std::string>> left_out;  // interface -> who is only on its network
    for (const auto& a : heard->participants) {
      if (a.domain != d.domain || a.addresses.empty()) continue;
      std::set<std::string> nets;
      for (const auto& text : a.addresses)
        if (const auto addr = ipv4(text))
          for (const auto& i : host)
            if (!i.loopback && same_subnet(i, *addr)) nets.insert(i.name);
      if (nets.empty() || std::any_of(nets.begin(), nets.end(), [&](const auto& n) { return joined.count(n); }))
        continue;  // not on a network of this host, or also on one the daemon is on
      left_out[*nets.begin()].push_back((a.name.empty() ? a.guid_prefix : "'" + a.name + "'") + " at " +
                                        join(a.addresses, ", "));
    }
    for (const auto& [itf, who_there] : left_out)
      r.add(Verdict::warn, "network",
            "on " + dom + " " + join(who_there, ", ") + (who_there.size() == 1 ? " is" : " are") + " on the network of " +
                itf + ", which the daemon is not on (it is on " + join({joined.begin(), joined.end()}, ", ") +
                "): add --interface " + itf + " (\"interfaces\" in the config), or take it out of exclude-interfaces");
  }
}

void check_devices(Report& r, const std::vector<rsdiscovery::Device>& devices, const rsdiscovery::Health& health) {
  for (const auto& d : devices) {
    // Listed cameras: what is said of them explains no missing camera.
    for (const auto& w : d.warnings)
      r.add(Verdict::info, "usb", (d.name.empty() ? d.id : d.name) + " " + d.serial + ": " + w);
    if (d.recovery)
      r.add(Verdict::info, "camera", (d.name.empty() ? d.id : d.name) + " " + d.serial +
                                         " runs its recovery firmware: update its firmware");
  }
  const auto doc = rsdiscovery::json::parse_or_null(health.json);
  const auto* usb = find(doc, "usb");
  const std::string state = text_or(find(usb, "state"));
  if (state == "unavailable")
    r.add(Verdict::warn, "usb", "the daemon cannot watch USB: " + text_or(find(usb, "error"), "(no reason given)"));
  else if (state == "off")
    r.add(Verdict::info, "usb", "the daemon does not watch USB (--no-usb or \"usb\": false)");
  else if (!state.empty())
    r.add(Verdict::ok, "usb", "the daemon watches USB (" + state + ")");
}

// The HTTP address, which lives in two places under systemd: the socket unit's
// ListenStream= (what the daemon listens on) and the configuration's "http" (what
// clients and this command go by when the daemon cannot be asked). The daemon says
// whether they agree (/healthz "http"; older daemons do not).
void check_http(Report& r, const rsdiscovery::Health& health) {
  const auto doc = rsdiscovery::json::parse_or_null(health.json);
  const auto* http = find(doc, "http");
  if (!http || !http->IsObject()) return;
  const std::string listening = text_or(find(http, "listening")), configured = text_or(find(http, "configured"));
  const bool systemd = text_or(find(http, "from")) == "systemd";
  if (!rsdiscovery::json::boolean(find(http, "agrees")).value_or(true)) {
    r.add(Verdict::warn, "http",
          "the daemon listens for HTTP on " + (listening.empty() ? std::string("nothing") : listening) +
              " (its socket unit's ListenStream=), but its configuration's \"http\" says " + configured +
              ": clients going by the configuration find no daemon there. Under systemd the socket unit decides: "
              "change the address with 'systemctl edit rs-discoveryd.socket', and make \"http\" the same or leave "
              "it out");
    return;
  }
  if (listening.empty())
    r.add(Verdict::info, "http", "the daemon does not listen for HTTP (\"http\": \"off\"): only its Unix socket answers");
  else
    r.add(Verdict::ok, "http", "the daemon listens for HTTP on " + listening +
                                   (systemd ? " (its socket unit's" + std::string(configured.empty() ? ")" : ", as configured)")
                                            : ""));
}

}  // namespace rsdiscover::doctor
