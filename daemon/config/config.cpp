#include "config/config.hpp"

#include "rsd_model/socket_path.hpp"

#include <nlohmann/json.hpp>

#include <charconv>
#include <cstring>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <unistd.h>

namespace rsd {
namespace {

int parse_domain(const std::string& text, const std::string& where) {
  int value = -1;
  const auto* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end || value < 0 || value > kMaxDomain)
    throw ConfigError(where + ": DDS domain must be a whole number from 0 to " +
                      std::to_string(kMaxDomain) + ", not '" + text + "'");
  return value;
}

// "HOST:PORT", "[v6]:PORT" or "off".
void parse_http(const std::string& text, Config& config, const std::string& where) {
  config.http_set = true;
  if (text == "off") {
    config.http_host.clear();
    return;
  }
  const auto colon = text.rfind(':');
  std::string host = colon == std::string::npos ? "" : text.substr(0, colon);
  const std::string port = colon == std::string::npos ? "" : text.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  int value = 0;
  auto [ptr, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
  if (host.empty() || port.empty() || ec != std::errc() || ptr != port.data() + port.size() ||
      value < 1 || value > 65535)
    throw ConfigError(where + ": expected HOST:PORT (for example 127.0.0.1:" +
                      std::to_string(kDefaultHttpPort) + ") or 'off', not '" + text + "'");
  config.http_host = host;
  config.http_port = value;
}

// A Host name (or address) the HTTP listener answers for; "*" for any.
std::string parse_allowed_host(const std::string& text, const std::string& where) {
  const bool bad = text.empty() || text.size() > 253 ||
                   text.find_first_of(" \t\r\n/?#@") != std::string::npos;
  if (bad)
    throw ConfigError(where + ": expected a host name or address as a browser sends it in Host (or '*'), not '" +
                      text + "'");
  return text;
}

// A network interface name or shell pattern. Linux names are 1-15 characters
// without '/' or whitespace; a pattern may be longer ("enp*s0*"), not unbounded.
std::string parse_interface_pattern(const std::string& text, const std::string& where) {
  const bool bad = text.empty() || text.size() > 64 || text.find_first_of(" \t\r\n/\"'<>&") != std::string::npos;
  if (bad)
    throw ConfigError(where + ": expected a network interface name or pattern (eth1, enp*), not '" + text + "'");
  return text;
}

void parse_socket(const std::string& text, Config& config, const std::string& where) {
  if (text.empty()) throw ConfigError(where + ": socket path is empty (use 'off' to disable)");
  config.socket_path = text == "off" ? "" : text;
}

void check_log_level(const std::string& level, const std::string& where) {
  static const std::set<std::string> kLevels{"error", "warning", "notice", "info", "debug"};
  if (!kLevels.count(level))
    throw ConfigError(where + ": log level must be one of error, warning, notice, info, debug; not '" +
                      level + "'");
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError("cannot read config file " + path + ": " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// A timeout in whole seconds, 1 to 300.
int parse_seconds(const std::string& text, const std::string& where) {
  int n = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
  if (ec != std::errc() || end != text.data() + text.size() || n < 1 || n > 300)
    throw ConfigError(where + ": must be a whole number of seconds from 1 to 300, not '" + text + "'");
  return n;
}

// A device cap: a whole number from 1 to 1,000,000.
std::size_t parse_limit(const std::string& text, const std::string& where) {
  std::size_t used = 0;
  long long n = 0;
  try {
    n = std::stoll(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || n < 1 || n > 1000000)
    throw ConfigError(where + ": must be a whole number from 1 to 1000000, not '" + text + "'");
  return static_cast<std::size_t>(n);
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
  auto want_string = [&](const std::string& key, const nlohmann::json& v) -> std::string {
    if (!v.is_string()) throw ConfigError(where + ": \"" + key + "\" must be a string");
    return v.get<std::string>();
  };
  for (const auto& [key, value] : doc.items()) {
    const std::string at = where + ": \"" + key + "\"";
    if (key == "domains") {
      if (!value.is_array() || value.empty())
        throw ConfigError(at + " must be a non-empty array of domain ids");
      std::vector<int> domains;
      for (const auto& d : value) {
        if (!d.is_number_integer()) throw ConfigError(at + " must hold whole numbers, not " + d.dump());
        domains.push_back(parse_domain(std::to_string(d.get<long long>()), at));
      }
      config.domains = domains;
    } else if (key == "socket") {
      parse_socket(want_string(key, value), config, at);
    } else if (key == "http") {
      parse_http(want_string(key, value), config, at);
    } else if (key == "usb") {
      if (!value.is_boolean()) throw ConfigError(at + " must be true or false");
      config.usb = value.get<bool>();
    } else if (key == "participant-name") {
      config.participant_name = want_string(key, value);
    } else if (key == "log-level") {
      config.log_level = want_string(key, value);
      check_log_level(config.log_level, at);
    } else if (key == "cyclonedds-config") {
      config.cyclonedds_config = want_string(key, value);
    } else if (key == "describe-eagerly") {
      // true, false, or the domains whose devices are described as they appear
      if (value.is_boolean()) {
        config.describe_eagerly_all = value.get<bool>();
        config.describe_eagerly.clear();
      } else if (value.is_array()) {
        config.describe_eagerly_all = false;
        config.describe_eagerly.clear();
        for (const auto& d : value) {
          if (!d.is_number_integer()) throw ConfigError(at + " must be true, false or a list of domain ids");
          config.describe_eagerly.push_back(parse_domain(std::to_string(d.get<long long>()), at));
        }
      } else {
        throw ConfigError(at + " must be true, false or a list of domain ids");
      }
    } else if (key == "describe-timeout") {
      config.describe_timeout_s = parse_seconds(value.is_number_integer() ? std::to_string(value.get<long long>())
                                                                         : value.dump(), at);
    } else if (key == "interfaces" || key == "exclude-interfaces") {
      if (!value.is_array()) throw ConfigError(at + " must be a list of interface names or patterns");
      auto& list = key == "interfaces" ? config.interfaces : config.exclude_interfaces;
      list.clear();
      for (const auto& i : value) {
        if (!i.is_string()) throw ConfigError(at + " must hold strings, not " + i.dump());
        list.push_back(parse_interface_pattern(i.get<std::string>(), at));
      }
    } else if (key == "allowed-hosts") {
      if (!value.is_array()) throw ConfigError(at + " must be a list of host names");
      config.allowed_hosts.clear();
      for (const auto& h : value) {
        if (!h.is_string()) throw ConfigError(at + " must hold strings, not " + h.dump());
        config.allowed_hosts.push_back(parse_allowed_host(h.get<std::string>(), at));
      }
    } else if (key == "max-clients") {
      config.max_clients = parse_limit(value.is_number_integer() ? std::to_string(value.get<long long>())
                                                                 : value.dump(), at);
    } else if (key == "max-devices-per-participant" || key == "max-devices-per-domain") {
      const std::size_t n = parse_limit(value.is_number_integer() ? std::to_string(value.get<long long>())
                                                                 : value.dump(), at);
      (key == "max-devices-per-domain" ? config.max_devices_per_domain : config.max_devices_per_participant) = n;
    } else if (key == "max-writers-per-participant" || key == "max-writers-per-domain") {
      const std::size_t n = parse_limit(value.is_number_integer() ? std::to_string(value.get<long long>())
                                                                 : value.dump(), at);
      (key == "max-writers-per-domain" ? config.max_writers_per_domain : config.max_writers_per_participant) = n;
    } else {
      throw ConfigError(where + ": unknown key \"" + key +
                        "\" (known: domains, socket, http, usb, participant-name, log-level, "
                        "cyclonedds-config, max-devices-per-participant, max-devices-per-domain, max-writers-per-participant, "
                        "max-writers-per-domain, interfaces, exclude-interfaces, describe-timeout, describe-eagerly, "
                        "allowed-hosts, max-clients)");
    }
  }
}

CommandLine parse_command_line(int argc, const char* const* argv) {
  CommandLine cl;
  Config flags_only;  // collects what the flags set, to apply over the file
  bool set_domains = false, set_socket = false, set_http = false, set_usb = false, set_name = false,
       set_level = false, set_cyclone = false, set_per_participant = false, set_per_domain = false,
       set_writers_participant = false, set_writers_domain = false, set_interfaces = false, set_excluded = false,
       set_describe = false, set_eager = false, set_hosts = false, set_clients = false;
  std::string config_file;
  bool explicit_config = false;
  std::vector<int> domains;

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
    } else if (arg == "-d" || arg == "--domain") {
      domains.push_back(parse_domain(next(), "--domain"));
      set_domains = true;
    } else if (arg == "--socket") {
      parse_socket(next(), flags_only, "--socket");
      set_socket = true;
    } else if (arg == "--http") {
      parse_http(next(), flags_only, "--http");
      set_http = true;
    } else if (arg == "--no-usb") {
      flags_only.usb = false;
      set_usb = true;
    } else if (arg == "--participant-name") {
      flags_only.participant_name = next();
      set_name = true;
    } else if (arg == "--log-level") {
      flags_only.log_level = next();
      check_log_level(flags_only.log_level, "--log-level");
      set_level = true;
    } else if (arg == "--cyclonedds-config") {
      flags_only.cyclonedds_config = next();
      set_cyclone = true;
    } else if (arg == "--max-devices-per-participant") {
      flags_only.max_devices_per_participant = parse_limit(next(), arg);
      set_per_participant = true;
    } else if (arg == "--describe-eagerly") {
      const std::string v = next();
      if (v == "all") flags_only.describe_eagerly_all = true;
      else flags_only.describe_eagerly.push_back(parse_domain(v, arg));
      set_eager = true;
    } else if (arg == "--describe-timeout") {
      flags_only.describe_timeout_s = parse_seconds(next(), arg);
      set_describe = true;
    } else if (arg == "--allowed-host") {
      flags_only.allowed_hosts.push_back(parse_allowed_host(next(), arg));
      set_hosts = true;
    } else if (arg == "--max-clients") {
      flags_only.max_clients = parse_limit(next(), arg);
      set_clients = true;
    } else if (arg == "--max-devices-per-domain") {
      flags_only.max_devices_per_domain = parse_limit(next(), arg);
      set_per_domain = true;
    } else if (arg == "--interface") {
      if (!set_interfaces) flags_only.interfaces.clear();
      flags_only.interfaces.push_back(parse_interface_pattern(next(), arg));
      set_interfaces = true;
    } else if (arg == "--exclude-interface") {
      if (!set_excluded) flags_only.exclude_interfaces.clear();
      const std::string v = next();
      if (v != "none") flags_only.exclude_interfaces.push_back(parse_interface_pattern(v, arg));
      set_excluded = true;
    } else if (arg == "--max-writers-per-participant") {
      flags_only.max_writers_per_participant = parse_limit(next(), arg);
      set_writers_participant = true;
    } else if (arg == "--max-writers-per-domain") {
      flags_only.max_writers_per_domain = parse_limit(next(), arg);
      set_writers_domain = true;
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
  if (set_domains) config.domains = domains;
  if (set_socket) config.socket_path = flags_only.socket_path;
  if (set_http) {
    config.http_host = flags_only.http_host;
    config.http_port = flags_only.http_port;
    config.http_set = true;
  }
  if (set_usb) config.usb = flags_only.usb;
  if (set_name) config.participant_name = flags_only.participant_name;
  if (set_level) config.log_level = flags_only.log_level;
  if (set_cyclone) config.cyclonedds_config = flags_only.cyclonedds_config;
  if (set_per_participant) config.max_devices_per_participant = flags_only.max_devices_per_participant;
  if (set_per_domain) config.max_devices_per_domain = flags_only.max_devices_per_domain;
  if (set_interfaces) config.interfaces = flags_only.interfaces;
  if (set_excluded) config.exclude_interfaces = flags_only.exclude_interfaces;
  if (set_writers_participant) config.max_writers_per_participant = flags_only.max_writers_per_participant;
  if (set_writers_domain) config.max_writers_per_domain = flags_only.max_writers_per_domain;
  if (set_describe) config.describe_timeout_s = flags_only.describe_timeout_s;
  if (set_hosts) config.allowed_hosts = flags_only.allowed_hosts;
  if (set_clients) config.max_clients = flags_only.max_clients;
  if (set_eager) {
    config.describe_eagerly_all = flags_only.describe_eagerly_all;
    config.describe_eagerly = flags_only.describe_eagerly;
  }

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
      --http HOST:PORT|off   HTTP listener for the API (default: 127.0.0.1:8035)
      --allowed-host NAME    a Host name HTTP answers for besides localhost and its own
                             address (repeat; '*': any). Others get 421, which keeps web
                             pages (DNS rebinding) from reading the API through a browser
      --max-clients N        API connections at once, both listeners (default: 4096);
                             beyond, new clients get 503 with Retry-After
      --no-usb               do not watch local USB cameras
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
  -V, --version              print the version and exit
  -h, --help                 print this help and exit

Config file keys: domains, socket, http, usb, participant-name, log-level,
cyclonedds-config, max-devices-per-participant, max-devices-per-domain,
max-writers-per-participant, max-writers-per-domain, interfaces and
exclude-interfaces (lists), describe-timeout, describe-eagerly (true, false or a list of domains), allowed-hosts
(a list), max-clients; otherwise the same meanings as the flags. The HTTP and socket
settings (http, socket, allowed-hosts, max-clients) take effect at start, not on SIGHUP.

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
