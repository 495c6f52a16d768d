// rs-discover doctor: why a camera is missing. Checks the usual causes, from what the
// daemon knows (its domains, the participants it hears, its cameras, USB), from
// what this host hears on every DDS domain's discovery port (spdp.hpp) and, when the
// daemon runs on this host, from the host's network (interfaces, multicast route),
// and says what to do, one line each.
#include "doctor.hpp"

namespace rsdiscover::doctor {
namespace {

int run(const ParsedArgs& args) {
  if (args.positional.size() > 1) throw UsageError("unexpected argument '" + args.positional[1] + "'");
  const double listen_s = args.get_seconds("listen", 3);
  if (listen_s > 60) throw UsageError("--listen wants at most 60 seconds");
  Report report;
  auto client = make_client(args);
  rsdiscovery::Health health;
  try {
    health = client.health();
  } catch (const rsdiscovery::Error& e) {
    const std::string hint = unreachable_hint(e, client.endpoint());
    const bool whole = e.code() == rsdiscovery::ErrorCode::permission_denied &&
                       client.endpoint().kind == rsdiscovery::Endpoint::Kind::unix_socket;
    report.add(Verdict::fail, "daemon", whole ? hint : std::string(e.what()) + (hint.empty() ? "" : "; " + hint));
    report.print(args.has("json"));
    return e.code() == rsdiscovery::ErrorCode::not_running || e.code() == rsdiscovery::ErrorCode::permission_denied
               ? kUnreachable
               : kBadReply;
  }
  report.add(Verdict::ok, "daemon", "rs-discoveryd " + health.version + " answers at " + client.endpoint().to_string() +
                                        (health.complete ? "" : " (its first discovery still runs: look again in a few seconds)"));
  // The cameras it expects and misses come first: the question a robot's operator asks.
  std::optional<rsdiscovery::Expected> expected;
  try {
    expected = client.expected();
  } catch (const rsdiscovery::Error& e) {
    if (e.code() != rsdiscovery::ErrorCode::not_found) throw;  // an older daemon: no such route
  }
  check_expected(report, expected);
  if (!args.positional.empty()) check_camera(report, client, args.positional[0]);
  const auto domains = client.domains();
  // Listened to before the daemon's participants are read, so that whoever is
  // heard here is in the daemon's answer too.
  std::optional<spdp::Heard> heard;
  if (listen_s > 0) heard = spdp::listen(std::chrono::milliseconds(static_cast<long>(listen_s * 1000)));
  const auto participants = client.participants();
  const auto devices = client.list_devices();
  if (args.has("fix-librealsense")) return fix_librealsense(devices, domains);
  check_domains(report, domains);
  check_other_domains(report, domains, heard, listen_s);
  check_participants(report, participants, domains);
  if (endpoint_is_local(client.endpoint().to_string())) {
    check_host_network(report, participants);
    check_networks(report, domains, heard);
  } else
    report.add(Verdict::info, "interface", "the daemon is on another host: its network is not checked from here");
  check_devices(report, devices, health);
  check_sharing(report, devices, participants, domains);
  check_http(report, health);
  try {
    check_history(report, client.history(0));
  } catch (const rsdiscovery::Error&) {  // a daemon without /v1/history: nothing to say
  }
  check_librealsense(report, devices, domains);
  report.add(Verdict::info, "cameras", std::to_string(devices.size()) + " camera" + (devices.size() == 1 ? "" : "s") +
                                           " listed ('rs-discover list')");
  return report.print(args.has("json"));
}

}  // namespace
}  // namespace rsdiscover::doctor

namespace rsdiscover {

const Command kDoctorCommand = {
    "doctor",
    "find out why a camera is missing or busy",
    "doctor [--json] [--listen S] [ID]",
    "Check the usual reasons a camera is not listed, and say what to do, one line each:\n"
    "the DDS domains the daemon joined (cameras use 0 unless configured otherwise), who\n"
    "announces itself on the other domains (heard here on every domain's discovery port\n"
    "for --listen seconds), who it hears on its own, participants heard but not answering\n"
    "(a firewall on the domain's UDP ports), realdds servers whose cameras never arrive,\n"
    "a topic-root announced by two servers, link-local or container-bridge addresses,\n"
    "and, when the daemon runs on this host, its multicast route and which network the\n"
    "participants are on; USB cameras on a USB 2 link and USB the daemon cannot watch;\n"
    "an HTTP address in the configuration that its socket unit does not listen on;\n"
    "which hosts share USB cameras with it (share-usb), and other daemons that share none;\n"
    "the expected cameras it does not list (first); and whether librealsense programs of\n"
    "this user (under sudo: of the invoking user and of root) will see the network cameras\n"
    "listed, from ~/.realsense-config.json (DDS off by default, domain, device-mask).\n"
    "With ID (an id, serial or topic-root), first the camera itself: listed or why not,\n"
    "and who uses it: a client streaming a network camera is named with its host, as a\n"
    "new open-streams asking other profiles is refused while it streams (warn); the\n"
    "processes holding a USB camera's device nodes (see 'rs-discover clients').\n"
    "'info' lines are worth knowing and explain none.\n"
    "Exit status: 0 nothing found explains a missing camera; 1 a line says 'warn' or\n"
    "'fail' (a likely cause); 2 usage error; 3 the daemon cannot be asked (not running,\n"
    "or no rights on its socket); 4 something other than rs-discoveryd answers, or its\n"
    "reply was not understood.",
    {
        {"json", 'j', nullptr, "print {\"findings\": [{\"verdict\", \"topic\", \"text\"}, ...]}"},
        {"listen", 0, "S", "listen S seconds for participants on other domains (default 3; 0: do not)"},
        {"fix-librealsense", 0, nullptr,
         "turn on DDS in ~/.realsense-config.json (under sudo also the invoking user's) for the domain and "
         "product lines of the cameras listed; other keys kept, the old file kept as .bak"},
    },
    doctor::run,
};

}  // namespace rsdiscover
