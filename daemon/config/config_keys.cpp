// The table of configuration keys (config_keys.hpp) and the value parsers it uses.
#include "config/config_keys.hpp"

#include <nlohmann/json.hpp>

#include <grp.h>

#include <algorithm>
#include <charconv>
#include <iterator>
#include <set>
#include <vector>

namespace rsd {
namespace {

using nlohmann::json;

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

// Resolved now, so that a group that does not exist is a configuration error at
// start (exit 2), not a socket left to the daemon's own group.
void parse_socket_group(const std::string& text, Config& config, const std::string& where) {
  if (text.empty()) throw ConfigError(where + ": socket group is empty");
  std::vector<char> buf(16384);
  group g{};
  group* found = nullptr;
  const int rc = getgrnam_r(text.c_str(), &g, buf.data(), buf.size(), &found);
  if (rc != 0 || !found)
    throw ConfigError(where + ": no group '" + text + "' on this host (make it with 'groupadd " + text + "')");
  config.socket_group = text;
  config.socket_gid = static_cast<int>(found->gr_gid);
}

void parse_socket(const std::string& text, Config& config, const std::string& where) {
  if (text.empty()) throw ConfigError(where + ": socket path is empty (use 'off' to disable)");
  config.socket_path = text == "off" ? "" : text;
}

std::string check_log_level(const std::string& level, const std::string& where) {
  static const std::set<std::string> kLevels{"error", "warning", "notice", "info", "debug"};
  if (!kLevels.count(level))
    throw ConfigError(where + ": log level must be one of error, warning, notice, info, debug; not '" +
                      level + "'");
  return level;
}

// A timeout in whole seconds, 1 to 300.
int parse_seconds(const std::string& text, const std::string& where) {
  int n = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
  if (ec != std::errc() || end != text.data() + text.size() || n < 1 || n > 300)
    throw ConfigError(where + ": must be a whole number of seconds from 1 to 300, not '" + text + "'");
  return n;
}

// The removal grace: 0 (off, realdds' own behaviour) to 300 seconds.
int parse_grace(const std::string& text, const std::string& where) {
  int n = -1;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
  if (ec != std::errc() || end != text.data() + text.size() || n < 0 || n > 300)
    throw ConfigError(where + ": must be a whole number of seconds from 0 to 300, not '" + text + "'");
  return n;
}

// A cap: a whole number from 1 to 1,000,000.
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

// A file's number as a flag would spell it, so both meet one parser and one message.
std::string number_text(const json& v) {
  return v.is_number_integer() ? std::to_string(v.get<long long>()) : v.dump();
}

std::string want_string(const json& v, const std::string& at) {
  if (!v.is_string()) throw ConfigError(at + " must be a string");
  return v.get<std::string>();
}

// A JSON list of strings, each checked by `parse`.
std::vector<std::string> string_list(const json& v, const std::string& at, const char* what,
                                     std::string (*parse)(const std::string&, const std::string&)) {
  if (!v.is_array()) throw ConfigError(at + " must be a list of " + what);
  std::vector<std::string> out;
  for (const auto& s : v) {
    if (!s.is_string()) throw ConfigError(at + " must hold strings, not " + s.dump());
    out.push_back(parse(s.get<std::string>(), at));
  }
  return out;
}

template <auto... Fields>
bool same(const Config& a, const Config& b) {
  return ((a.*Fields == b.*Fields) && ...);
}

template <auto... Fields>
void copy(const Config& from, Config& to) {
  ((to.*Fields = from.*Fields), ...);
}

// A key whose flag and file value are one text, checked by `Parse`.
template <auto Field, auto Parse>
void text_from_file(const json& v, Config& c, const std::string& at) {
  c.*Field = Parse(want_string(v, at), at);
}
template <auto Field, auto Parse>
void text_from_flag(const std::string& text, Config& c, bool, const std::string& where) {
  c.*Field = Parse(text, where);
}
template <auto Field, auto Parse>
void number_from_file(const json& v, Config& c, const std::string& at) {
  c.*Field = Parse(number_text(v), at);
}

std::string any_text(const std::string& text, const std::string&) { return text; }

// A key holding a list of strings, each checked by `Parse`: the file gives the whole
// list; the flag repeats, its first use replacing the file's list (or the default).
template <auto Field, auto Parse, const char* What>
void list_from_file(const json& v, Config& c, const std::string& at) {
  c.*Field = string_list(v, at, What, Parse);
}
template <auto Field, auto Parse>
void list_from_flag(const std::string& text, Config& c, bool first, const std::string& where) {
  if (first) (c.*Field).clear();
  (c.*Field).push_back(Parse(text, where));
}

// The expected cameras: the file gives the list, each a string or an object; the flag
// repeats ("front=123456"), its first use replacing the file's list. One key once.
void add_expected(std::vector<model::ExpectedCamera>& list, const std::optional<model::ExpectedCamera>& camera,
                  const std::string& error, const std::string& where) {
  if (!camera) throw ConfigError(where + ": " + error);
  for (const auto& e : list)
    if (e.key() == camera->key() || (!e.name.empty() && e.name == camera->name))
      throw ConfigError(where + ": '" + (e.key() == camera->key() ? e.key() : e.name) + "' is expected twice");
  if (list.size() >= model::kMaxExpected)
    throw ConfigError(where + ": at most " + std::to_string(model::kMaxExpected) + " expected cameras");
  list.push_back(*camera);
}

void expect_from_file(const json& v, Config& c, const std::string& at) {
  if (!v.is_array()) throw ConfigError(at + " must be a list of serials or topic-roots (\"front=123456\", ...)");
  c.expect.clear();
  for (const auto& e : v) {
    std::string error;
    const auto camera = model::expected_from_json(e, &error);
    add_expected(c.expect, camera, error, at);
  }
}

void expect_from_flag(const std::string& text, Config& c, bool first, const std::string& where) {
  if (first) c.expect.clear();
  std::string error;
  const auto camera = model::parse_expected(text, &error);
  add_expected(c.expect, camera, error, where);
}

constexpr char kHostNames[] = "host names";
constexpr char kInterfacePatterns[] = "interface names or patterns";

#define RSD_LIMIT(file, field, reload)                                                                \
  ConfigKey {                                                                                         \
    file, file, '\0', true, reload, number_from_file<&Config::field, parse_limit>,                    \
        text_from_flag<&Config::field, parse_limit>, copy<&Config::field>, same<&Config::field>       \
  }

const ConfigKey kKeys[] = {
    {"domains", "domain", 'd', true, Reload::live,
     [](const json& v, Config& c, const std::string& at) {
       if (!v.is_array() || v.empty()) throw ConfigError(at + " must be a non-empty array of domain ids");
       std::vector<int> domains;
       for (const auto& d : v) {
         if (!d.is_number_integer()) throw ConfigError(at + " must hold whole numbers, not " + d.dump());
         domains.push_back(parse_domain(std::to_string(d.get<long long>()), at));
       }
       c.domains = domains;
     },
     [](const std::string& text, Config& c, bool first, const std::string& where) {
       if (first) c.domains.clear();
       c.domains.push_back(parse_domain(text, where));
     },
     copy<&Config::domains>, same<&Config::domains>},
    {"socket", "socket", '\0', true, Reload::restart,
     [](const json& v, Config& c, const std::string& at) { parse_socket(want_string(v, at), c, at); },
     [](const std::string& text, Config& c, bool, const std::string& where) { parse_socket(text, c, where); },
     copy<&Config::socket_path>, same<&Config::socket_path>},
    {"socket-group", "socket-group", '\0', true, Reload::restart,
     [](const json& v, Config& c, const std::string& at) { parse_socket_group(want_string(v, at), c, at); },
     [](const std::string& text, Config& c, bool, const std::string& where) { parse_socket_group(text, c, where); },
     copy<&Config::socket_group, &Config::socket_gid>, same<&Config::socket_group>},
    {"http", "http", '\0', true, Reload::restart,
     [](const json& v, Config& c, const std::string& at) { parse_http(want_string(v, at), c, at); },
     [](const std::string& text, Config& c, bool, const std::string& where) { parse_http(text, c, where); },
     copy<&Config::http_host, &Config::http_port, &Config::http_set>,
     same<&Config::http_host, &Config::http_port>},
    {"allowed-hosts", "allowed-host", '\0', true, Reload::restart,
     list_from_file<&Config::allowed_hosts, parse_allowed_host, kHostNames>,
     list_from_flag<&Config::allowed_hosts, parse_allowed_host>, copy<&Config::allowed_hosts>,
     same<&Config::allowed_hosts>},
    RSD_LIMIT("max-clients", max_clients, Reload::restart),
    {"usb", "no-usb", '\0', false, Reload::live,
     [](const json& v, Config& c, const std::string& at) {
       if (!v.is_boolean()) throw ConfigError(at + " must be true or false");
       c.usb = v.get<bool>();
     },
     [](const std::string&, Config& c, bool, const std::string&) { c.usb = false; },
     copy<&Config::usb>, same<&Config::usb>},
    {"share-usb", "share-usb", '\0', false, Reload::restart,
     [](const json& v, Config& c, const std::string& at) {
       if (!v.is_boolean()) throw ConfigError(at + " must be true or false");
       c.share_usb = v.get<bool>();
     },
     [](const std::string&, Config& c, bool, const std::string&) { c.share_usb = true; },
     copy<&Config::share_usb>, same<&Config::share_usb>},
    {"participant-name", "participant-name", '\0', true, Reload::restart,
     text_from_file<&Config::participant_name, any_text>, text_from_flag<&Config::participant_name, any_text>,
     copy<&Config::participant_name>, same<&Config::participant_name>},
    {"interfaces", "interface", '\0', true, Reload::live,
     list_from_file<&Config::interfaces, parse_interface_pattern, kInterfacePatterns>,
     list_from_flag<&Config::interfaces, parse_interface_pattern>, copy<&Config::interfaces>,
     same<&Config::interfaces>},
    {"exclude-interfaces", "exclude-interface", '\0', true, Reload::live,
     list_from_file<&Config::exclude_interfaces, parse_interface_pattern, kInterfacePatterns>,
     [](const std::string& text, Config& c, bool first, const std::string& where) {
       if (first) c.exclude_interfaces.clear();  // the defaults go; 'none' leaves none
       if (text != "none") c.exclude_interfaces.push_back(parse_interface_pattern(text, where));
     },
     copy<&Config::exclude_interfaces>, same<&Config::exclude_interfaces>},
    {"cyclonedds-config", "cyclonedds-config", '\0', true, Reload::restart,
     text_from_file<&Config::cyclonedds_config, any_text>, text_from_flag<&Config::cyclonedds_config, any_text>,
     copy<&Config::cyclonedds_config>, same<&Config::cyclonedds_config>},
    {"log-level", "log-level", '\0', true, Reload::live, text_from_file<&Config::log_level, check_log_level>,
     text_from_flag<&Config::log_level, check_log_level>, copy<&Config::log_level>, same<&Config::log_level>},
    RSD_LIMIT("max-devices-per-participant", max_devices_per_participant, Reload::live),
    RSD_LIMIT("max-devices-per-domain", max_devices_per_domain, Reload::live),
    RSD_LIMIT("max-writers-per-participant", max_writers_per_participant, Reload::restart),
    RSD_LIMIT("max-writers-per-domain", max_writers_per_domain, Reload::restart),
    {"describe-timeout", "describe-timeout", '\0', true, Reload::restart,
     number_from_file<&Config::describe_timeout_s, parse_seconds>,
     text_from_flag<&Config::describe_timeout_s, parse_seconds>, copy<&Config::describe_timeout_s>,
     same<&Config::describe_timeout_s>},
    {"describe-eagerly", "describe-eagerly", '\0', true, Reload::restart,
     // true, false, or the domains whose devices are described as they appear
     [](const json& v, Config& c, const std::string& at) {
       if (!v.is_boolean() && !v.is_array()) throw ConfigError(at + " must be true, false or a list of domain ids");
       c.describe_eagerly_all = v.is_boolean() && v.get<bool>();
       c.describe_eagerly.clear();
       if (v.is_boolean()) return;
       for (const auto& d : v) {
         if (!d.is_number_integer()) throw ConfigError(at + " must be true, false or a list of domain ids");
         c.describe_eagerly.push_back(parse_domain(std::to_string(d.get<long long>()), at));
       }
     },
     [](const std::string& text, Config& c, bool, const std::string& where) {
       if (text == "all") c.describe_eagerly_all = true;
       else c.describe_eagerly.push_back(parse_domain(text, where));
     },
     copy<&Config::describe_eagerly_all, &Config::describe_eagerly>,
     same<&Config::describe_eagerly_all, &Config::describe_eagerly>},
    {"removal-grace", "removal-grace", '\0', true, Reload::restart, number_from_file<&Config::removal_grace_s, parse_grace>,
     text_from_flag<&Config::removal_grace_s, parse_grace>, copy<&Config::removal_grace_s>,
     same<&Config::removal_grace_s>},
    {"expect", "expect", '\0', true, Reload::live, expect_from_file, expect_from_flag, copy<&Config::expect>,
     same<&Config::expect>},
};

#undef RSD_LIMIT

}  // namespace

std::span<const ConfigKey> config_keys() { return kKeys; }

const ConfigKey* find_file_key(std::string_view key) {
  const auto it = std::find_if(std::begin(kKeys), std::end(kKeys), [&](const ConfigKey& k) { return k.file == key; });
  return it == std::end(kKeys) ? nullptr : &*it;
}

const ConfigKey* find_flag(std::string_view arg) {
  const auto it = std::find_if(std::begin(kKeys), std::end(kKeys), [&](const ConfigKey& k) {
    return (arg.starts_with("--") && arg.substr(2) == k.flag) ||
           (k.short_flag && arg.size() == 2 && arg[0] == '-' && arg[1] == k.short_flag);
  });
  return it == std::end(kKeys) ? nullptr : &*it;
}

std::vector<std::string> changed_keys(const Config& a, const Config& b) {
  std::vector<std::string> out;
  for (const auto& k : kKeys)
    if (!k.same(a, b)) out.push_back(k.file);
  return out;
}

std::vector<std::string> restart_only_changes(const Config& running, const Config& next) {
  std::vector<std::string> out;
  for (const auto& k : kKeys)
    if (k.reload == Reload::restart && !k.same(running, next)) out.push_back(k.file);
  return out;
}

}  // namespace rsd
