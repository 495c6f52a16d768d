// Flags and the JSON config file, each read through the one key table
// (config_keys.hpp) and merged into one Config: defaults, the file, then flags.
#include "config/config.hpp"

#include "config/config_check.hpp"
#include "config/config_keys.hpp"

#include "rsd_model/socket_path.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstring>
#include <cstdlib>
#include <fstream>
#include <set>
#include <vector>
#include <sstream>
#include <unistd.h>

namespace rsd {
namespace {

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError("cannot read config file " + path + ": " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Edits between two words (Levenshtein, a swap of two neighbours counting one), for
// "did you mean": a typo is one or two.
std::size_t edits(const std::string& a, const std::string& b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i)
    for (std::size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[a.size()][b.size()];
}

// 'WHERE:LINE:COLUMN: unknown key "x"; did you mean "y"? (known: ...)', the place as an
// editor jumps to it. No ': "' in it: --check-config would take it for a bad value's.
std::string unknown_key(const std::string& where, const std::string& text, const std::string& key) {
  std::string known, nearest;
  std::size_t best = 3;  // more edits than two is another word, not a typo
  for (const auto& each : config_keys()) {
    known += (known.empty() ? "" : ", ") + std::string(each.file);
    // A key far longer than any known one is no typo of one (and costs its length squared).
    if (key.size() > 64) continue;
    if (const std::size_t d = edits(key, each.file); d < best) {
      best = d;
      nearest = each.file;
    }
  }
  const auto [line, column] = top_level_key_position(text, key);
  return where + (line ? ":" + std::to_string(line) + ":" + std::to_string(column) : "") + ": unknown key \"" + key +
         "\"" + (nearest.empty() ? "" : "; did you mean \"" + nearest + "\"?") + " (known: " + known + ")";
}

}  // namespace

// The rule is the clients' too (proto/model), so they find the socket we listen on.
std::string default_socket_path() { return rsd::model::default_socket_path(); }

void apply_config_json(const std::string& text, Config& config) {
  const std::string where = config.config_file.empty() ? "config" : config.config_file;
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    // Not only parse_error: a number too large for a double is out_of_range (406),
    // found by fuzz_config; uncaught, it ended the daemon on a reload.
    throw ConfigError(where + ": not valid JSON: " + e.what());
  }
  if (!doc.is_object()) throw ConfigError(where + ": must be a JSON object");
  for (const auto& [key, value] : doc.items()) {
    const ConfigKey* k = find_file_key(key);
    if (!k) throw ConfigError(unknown_key(where, text, key));
    k->from_file(value, config, where + ": \"" + key + "\"");
  }
}

CommandLine parse_command_line(int argc, const char* const* argv) {
  CommandLine cl;
  Config flags_only;  // collects what the flags set, to apply over the file
  std::vector<const ConfigKey*> set;  // the keys flags set, each once
  std::string config_file;
  bool explicit_config = false;

  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    std::string value;
    bool has_inline = false;
    if (arg.rfind("--", 0) == 0) {
      if (auto eq = arg.find('='); eq != std::string::npos) {
        value = arg.substr(eq + 1);
        arg = arg.substr(0, eq);
        has_inline = true;
      }
    }
    auto next = [&]() -> std::string {
      if (has_inline) return value;
      if (i + 1 >= argc) throw ConfigError(arg + " needs a value (see --help)");
      return argv[++i];
    };
    if (arg == "-h" || arg == "--help") {
      cl.action = CommandAction::help;
      return cl;
    } else if (arg == "-V" || arg == "--version") {
      cl.action = CommandAction::version;
      return cl;
    } else if (arg == "-c" || arg == "--config") {
      config_file = next();
      explicit_config = true;
    } else if (arg == "--check-config") {
      // As nginx -t: validate FILE (or --config's, or the default one) and exit.
      cl.action = CommandAction::check_config;
      if (has_inline || (i + 1 < argc && argv[i + 1][0] != '-')) {
        config_file = next();
        explicit_config = true;
      }
    } else if (const ConfigKey* k = find_flag(arg)) {
      const bool first = std::find(set.begin(), set.end(), k) == set.end();
      k->from_flag(k->takes_value ? next() : std::string(), flags_only, first, std::string("--") + k->flag);
      if (first) set.push_back(k);
    } else {
      throw ConfigError("unknown argument '" + arg + "' (see --help)");
    }
  }

  Config& config = cl.config;
  config.socket_path = default_socket_path();
  if (!explicit_config && access(kDefaultConfigFile, F_OK) == 0) config_file = kDefaultConfigFile;
  if (!config_file.empty()) {
    config.config_file = config_file;
    apply_config_json(read_file(config_file), config);
  }
  for (const ConfigKey* k : set) k->copy(flags_only, config);

  // The same domain twice would be two participants fighting over one table slot.
  std::set<int> unique(config.domains.begin(), config.domains.end());
  config.domains.assign(unique.begin(), unique.end());
  if (config.socket_path.empty() && config.http_host.empty())
    throw ConfigError("both the Unix socket and HTTP are off: nobody could ask the daemon anything");
  return cl;
}

const char* usage_text() {
  return R"(Usage: rs-discoveryd [OPTIONS]

Keeps a live table of Intel RealSense cameras announced over DDS (realdds) and
plugged in over USB, and serves it as JSON on a Unix socket and over HTTP.

Options:
  -c, --config FILE          JSON configuration file (default: /etc/rs-discoveryd/config.json
                             when it exists). Flags override the file.
      --check-config [FILE]  read and validate the configuration (FILE, else --config's or
                             the default file) with the other flags, print it, and exit:
                             0 valid, 1 invalid (FILE:LINE:COLUMN: what)
  -d, --domain N             DDS domain to watch, 0-232; repeat for several (default: 0)
      --socket PATH|off      Unix socket for the API (default: $RUNTIME_DIRECTORY/api.sock,
                             else /run/rs-discoveryd/api.sock for root,
                             else $XDG_RUNTIME_DIR/rs-discoveryd.sock)
      --socket-group GROUP   give the Unix socket this group (mode 0660), so that joining
                             GROUP grants the socket and nothing more (default: the
                             daemon's own group; under systemd: the socket unit's)
      --http HOST:PORT|off   HTTP listener for the API (default: 127.0.0.1:8035)
      --allowed-host NAME    a Host name HTTP answers for besides localhost and its own
                             address (repeat; '*': any). Others get 421, which keeps web
                             pages (DNS rebinding) from reading the API through a browser
      --max-clients N        API connections at once, both listeners (default: 4096);
                             beyond, new clients get 503 with Retry-After
      --no-usb               do not watch local USB cameras
      --share-usb            announce this host's USB cameras on every DDS domain, so that
                             the daemons of other hosts list them (default: off; other
                             hosts' shared cameras are listed either way)
      --participant-name NAME
                             DDS participant name others see (default: rs-discoveryd)
      --interface NAME|PATTERN
                             join the DDS domains on this network interface (repeat; shell
                             patterns such as enp*); default: every interface that is up, has
                             carrier, multicast and an IPv4 address, followed as the host's
                             network changes (interfaces and addresses coming and going)
      --exclude-interface PATTERN
                             never join these unless --interface names them (repeat; 'none'
                             for no exclusion); default: docker* veth* virbr* br-* lxcbr*
                             lxdbr* podman* cni* flannel* vnet*
      --cyclonedds-config XML|file://PATH
                             Cyclone DDS configuration for every domain (multicast, unicast
                             peers); default: CYCLONEDDS_URI or Cyclone's own. If it names
                             network interfaces, those are used and not followed
      --log-level LEVEL      error, warning, notice, info (default) or debug
      --max-devices-per-participant N
                             devices one DDS participant may announce (default: 128);
                             beyond it device-info is refused and counted
      --max-devices-per-domain N
                             devices one DDS domain may hold (default: 1024)
      --max-writers-per-participant N
                             device-info writers of one DDS participant the daemon follows
                             (default: 256; a realdds server has one per device, plus one);
                             beyond it a writer is refused and counted
      --max-writers-per-domain N
                             device-info writers of one DDS domain (default: 2048)
      --describe-timeout S   how long fetching a network camera's description (streams,
                             options) from its server may take (default: 30)
      --describe-eagerly N|all
                             describe the cameras of domain N (repeat) or of every domain
                             as they appear, not only when asked (default: when asked)
      --removal-grace S      keep a network camera whose server's lease ran out listed,
                             marked unresponsive, S seconds before removing it; heard
                             again by then, it is not removed (default: 0, at once)
      --expect [NAME=]SERIAL|[NAME=]TOPIC-ROOT
                             a camera this host is built with (repeat; front=123456,
                             wrist=realsense/D555_123): /v1/expected, /healthz, /metrics
                             and the service status say which are listed (a reload
                             applies a changed list)
  -V, --version              print the version and exit
  -h, --help                 print this help and exit

Config file keys: domains, socket, socket-group, http, usb, share-usb, participant-name,
log-level, cyclonedds-config, max-devices-per-participant, max-devices-per-domain,
max-writers-per-participant, max-writers-per-domain, interfaces and
exclude-interfaces (lists), describe-timeout, describe-eagerly (true, false or a list of
domains), removal-grace, allowed-hosts (a list), max-clients, expect (a list); otherwise
the same meanings as the flags. SIGHUP applies domains, usb, log-level,
interfaces, exclude-interfaces, expect, max-devices-per-participant and
max-devices-per-domain; the other keys take effect on restart. Devices past a
lowered cap leave the table as refused.

API: GET /v1/devices, /v1/devices/{id}, /v1/devices/{id}/description,
/v1/events (Server-Sent Events),
/v1/domains, /healthz, /metrics. For example:
  curl --unix-socket /run/rs-discoveryd/api.sock http://localhost/v1/devices
  curl http://127.0.0.1:8035/v1/devices

Signals: SIGTERM/SIGINT stop; SIGHUP re-reads the configuration (joins new domains,
leaves removed ones; an invalid file keeps the running configuration); SIGUSR1
rebuilds every domain's DDS participant (the daemon does this by itself when a
server is lost without saying 'stopping', as behind a network cut).
Under systemd: Type=notify (READY, STATUS, WATCHDOG), socket activation by
rs-discoveryd.socket. See rs-discoveryd(8).
Exit status: 0 stopped cleanly, 1 runtime failure, 2 bad usage or configuration.
)";
}

}  // namespace rsd
