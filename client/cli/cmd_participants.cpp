// rs-discover participants: who is on the daemon's DDS domains (GET /v1/participants).
#include "common.hpp"

namespace rsdiscover {
namespace {

int run(const ParsedArgs& args) {
  if (!args.positional.empty()) throw UsageError("unexpected argument '" + args.positional[0] + "'");
  if (args.has("json") && args.has("format")) throw UsageError("--json and --format exclude each other");
  std::optional<Template> format;  // a bad template: exit 2 before asking the daemon
  if (args.has("format")) format.emplace(args.get("format"), participant_fields());
  std::optional<int> domain;
  if (args.has("domain")) domain = args.get_int("domain", 0, 0, 232);
  auto client = make_client(args);
  auto all = client.participants(domain);
  std::vector<rsdiscovery::Participant> shown;
  for (auto& p : all)
    if (p.state == "alive" || args.has("all")) shown.push_back(std::move(p));
  if (args.has("json")) {
    std::string out = "{\"participants\":[";
    for (std::size_t i = 0; i < shown.size(); ++i) out += (i ? "," : "") + shown[i].json;
    std::fputs((out + "]}\n").c_str(), stdout);
    return kOk;
  }
  if (format) {
    std::vector<rsdiscovery::json::Document> docs;
    std::vector<const rsdiscovery::json::Value*> values;
    docs.reserve(shown.size());
    for (const auto& p : shown) values.push_back(&docs.emplace_back(rsdiscovery::json::parse_or_null(p.json)));
    format->check(values);
    std::string out;
    for (const auto& doc : docs) out += format->render(doc) + "\n";
    std::fputs(out.c_str(), stdout);
    return kOk;
  }
  Table table({"DOMAIN", "NAME", "VENDOR", "ADDRESSES", "STATE", "DEVICES", "LEASE", "SEEN", "GUID"});
  for (const auto& p : shown) {
    std::string name = p.name.empty() ? "-" : p.name;
    if (!p.process.empty()) name += " (" + p.process + (p.host.empty() ? "" : "@" + p.host) + ")";
    std::string devices = std::to_string(p.devices);
    if (p.never_announced) devices += " (never announced)";
    char lease[32] = "-";
    if (p.lease_seconds) std::snprintf(lease, sizeof lease, "%gs", *p.lease_seconds);
    // Alive ones: how long they have been there; gone ones: how long ago they went.
    const std::string seen = p.state == "alive" ? "for " + age_since(p.first_seen) : age_since(p.last_seen) + " ago";
    table.add({std::to_string(p.domain), name, p.vendor, p.addresses.empty() ? "-" : join(p.addresses, ","),
               p.state, devices, lease, seen, p.guid},
              {nullptr, nullptr, nullptr, nullptr, p.state == "alive" ? color::green : color::yellow,
               p.never_announced ? color::red : nullptr, nullptr, nullptr, nullptr});
  }
  table.print(stdout);
  if (shown.empty())
    std::fprintf(stderr, "no %sparticipants on %s (the daemon's own aside)%s\n", args.has("all") ? "" : "live ",
                 domain ? ("DDS domain " + std::to_string(*domain)).c_str() : "the daemon's DDS domains",
                 args.has("all") ? "" : "; --all shows those gone too");
  return kOk;
}

}  // namespace

const Command kParticipantsCommand = {
    "participants",
    "show who is on the DDS network (cameras, programs, tools)",
    "participants [-d N] [-a] [--json | --format TEMPLATE | --no-headers]",
    "Show every DDS participant the daemon hears on its domains: realdds cameras and\n"
    "servers (Fast DDS), librealsense and ROS programs, other DDS tools. For each: its\n"
    "name (and process and host, when it says), DDS vendor, addresses, how many cameras\n"
    "it announces, its lease and how long it has been there. A server whose cameras\n"
    "matched but never arrived is marked 'never announced': the network path (a\n"
    "firewall, multicast) or the server is at fault. The daemon's own participant is\n"
    "not listed. Without --all, only those alive now.\n"
    "--format prints one line per participant from a template of its fields, for example\n"
    "  rs-discover participants --format '{domain} {name} {addresses} {vendor}'\n"
    "(lists are joined by commas; a field participants do not have is an error, exit 2).",
    {
        {"domain", 'd', "N", "only participants on DDS domain N"},
        {"all", 'a', nullptr, "also those gone (the latest 256 per domain)"},
        {"json", 'j', nullptr, "print JSON as the API gives it: {\"participants\": [...]}"},
        kFormatOption,
        kNoHeadersOption,
    },
    run,
};

}  // namespace rsdiscover
