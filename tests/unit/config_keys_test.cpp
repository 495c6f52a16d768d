// The key table (daemon/config/config_keys) against what reads it and what repeats
// it in prose: the file and flag parsers, Service::reload's restart-only warning,
// the daemon's options (daemon_options) and --help. A key added to one and not the
// others fails here.
#include "config/config.hpp"
#include "config/config_keys.hpp"
#include "config/daemon_options.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

using rsd::Config;

namespace {

rsd::CommandLine parse(std::vector<std::string> args) {
  args.insert(args.begin(), "rs-discoveryd");
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  return rsd::parse_command_line(static_cast<int>(argv.size()), argv.data());
}

// Per key, a file value and flags that each set it to something other than the
// default, and to different things from each other where the key allows it.
struct Sample {
  const char* json;
  std::vector<std::string> flags;
};
const std::map<std::string, Sample>& samples() {
  static const std::map<std::string, Sample> s{
      {"domains", {"[1, 2]", {"-d", "3", "--domain=4"}}},
      {"socket", {"\"/tmp/from-file.sock\"", {"--socket", "/tmp/from-flag.sock"}}},
      {"socket-group", {"\"nogroup\"", {"--socket-group", "daemon"}}},  // groups every Debian has
      {"http", {"\"127.0.0.1:9001\"", {"--http", "[::1]:9002"}}},
      {"allowed-hosts", {"[\"a.example\"]", {"--allowed-host", "b.example", "--allowed-host", "c.example"}}},
      {"max-clients", {"200", {"--max-clients", "64"}}},
      {"usb", {"false", {"--no-usb"}}},
      {"share-usb", {"true", {"--share-usb"}}},
      {"participant-name", {"\"from-file\"", {"--participant-name", "from-flag"}}},
      {"interfaces", {"[\"eth1\"]", {"--interface", "enp*", "--interface", "wlan0"}}},
      {"exclude-interfaces", {"[\"eth9\"]", {"--exclude-interface", "none"}}},
      {"cyclonedds-config", {"\"<CycloneDDS/>\"", {"--cyclonedds-config", "file:///etc/cyclone.xml"}}},
      {"log-level", {"\"debug\"", {"--log-level", "error"}}},
      {"max-devices-per-participant", {"16", {"--max-devices-per-participant", "8"}}},
      {"max-devices-per-domain", {"2048", {"--max-devices-per-domain=64"}}},
      {"max-writers-per-participant", {"99", {"--max-writers-per-participant", "7"}}},
      {"max-writers-per-domain", {"5000", {"--max-writers-per-domain", "6"}}},
      {"describe-timeout", {"5", {"--describe-timeout", "9"}}},
      {"describe-eagerly", {"[0, 5]", {"--describe-eagerly", "all"}}},
      {"removal-grace", {"5", {"--removal-grace", "0"}}},
      {"expect", {"[\"front=111\"]", {"--expect", "wrist=222", "--expect", "realsense/D555_333"}}},
  };
  return s;
}

std::set<std::string> table_file_keys() {
  std::set<std::string> keys;
  for (const auto& k : rsd::config_keys()) keys.insert(k.file);
  return keys;
}

// The key names in a stretch of --help prose: words, not what is in parentheses.
std::set<std::string> names_in(std::string prose) {
  prose = std::regex_replace(prose, std::regex(R"(\([^)]*\))"), " ");
  std::set<std::string> names;
  const std::regex word("[a-z][a-z-]*");
  for (auto it = std::sregex_iterator(prose.begin(), prose.end(), word); it != std::sregex_iterator(); ++it)
    if (it->str() != "and") names.insert(it->str());
  return names;
}

std::string between(const std::string& text, const std::string& from, const std::string& to) {
  const auto a = text.find(from);
  const auto b = text.find(to, a == std::string::npos ? 0 : a);
  if (a == std::string::npos || b == std::string::npos) return "";
  return text.substr(a + from.size(), b - a - from.size());
}

}  // namespace

TEST(ConfigKeys, EverySampleIsAKeyAndEveryKeyHasASample) {
  std::set<std::string> sampled;
  for (const auto& [key, _] : samples()) sampled.insert(key);
  EXPECT_EQ(sampled, table_file_keys()) << "a new key needs a sample here";
}

TEST(ConfigKeys, RestartOnlyIsWhatReloadWarnsAbout) {
  // What Service::reload says "takes effect on restart" for; the rest it applies live.
  const std::vector<std::string> restart_only{
      "socket", "socket-group", "http", "allowed-hosts", "max-clients", "share-usb", "participant-name", "cyclonedds-config",
      "max-writers-per-participant",
      "max-writers-per-domain", "describe-timeout", "describe-eagerly", "removal-grace"};
  const Config running;
  Config all;
  for (const auto& k : rsd::config_keys()) {
    const std::string key = k.file;
    Config next;
    rsd::apply_config_json("{\"" + key + "\": " + samples().at(key).json + "}", next);
    rsd::apply_config_json("{\"" + key + "\": " + samples().at(key).json + "}", all);
    EXPECT_EQ(rsd::changed_keys(running, next), std::vector<std::string>{key}) << key;
    const bool restart = std::count(restart_only.begin(), restart_only.end(), key) > 0;
    EXPECT_EQ(rsd::restart_only_changes(running, next), restart ? std::vector<std::string>{key}
                                                                : std::vector<std::string>{})
        << key;
    EXPECT_TRUE(rsd::restart_only_changes(next, next).empty()) << key;
  }
  // All at once: the warning's list, in the order it has always had.
  EXPECT_EQ(rsd::restart_only_changes(running, all), restart_only);
}

TEST(ConfigKeys, TheFileSetsEveryKeyAndFlagsWinForEveryKey) {
  const std::string empty = ::testing::TempDir() + "/rsd-keys-empty.json";
  const std::string full = ::testing::TempDir() + "/rsd-keys-full.json";
  std::ofstream(empty) << "{}";
  std::string text;
  std::vector<std::string> flags;
  for (const auto& [key, sample] : samples()) {
    text += (text.empty() ? "{" : ", ") + ("\"" + key + "\": ") + sample.json;
    flags.insert(flags.end(), sample.flags.begin(), sample.flags.end());
  }
  std::ofstream(full) << text << "}";

  const Config defaults = parse({"--config", empty}).config;
  const Config from_file = parse({"--config", full}).config;
  std::vector<std::string> every;
  for (const auto& k : rsd::config_keys()) every.push_back(k.file);
  EXPECT_EQ(rsd::changed_keys(defaults, from_file), every);

  std::vector<std::string> over_file{"--config", full};
  over_file.insert(over_file.end(), flags.begin(), flags.end());
  std::vector<std::string> over_none{"--config", empty};
  over_none.insert(over_none.end(), flags.begin(), flags.end());
  const Config both = parse(over_file).config;
  EXPECT_TRUE(rsd::changed_keys(both, parse(over_none).config).empty());
  // Each flag's value, not the file's (usb: both say off; share-usb: both on).
  EXPECT_EQ(rsd::changed_keys(both, from_file), (std::vector<std::string>{
      "domains", "socket", "socket-group", "http", "allowed-hosts", "max-clients", "participant-name", "interfaces",
      "exclude-interfaces", "cyclonedds-config", "log-level", "max-devices-per-participant",
      "max-devices-per-domain", "max-writers-per-participant", "max-writers-per-domain", "describe-timeout",
      "describe-eagerly", "removal-grace", "expect"}));
  EXPECT_EQ(both.domains, (std::vector<int>{3, 4}));
  EXPECT_EQ(both.allowed_hosts, (std::vector<std::string>{"b.example", "c.example"}));
  EXPECT_TRUE(both.exclude_interfaces.empty());
}

TEST(ConfigKeys, TheUnknownKeyMessageListsEveryKey) {
  Config c;
  try {
    rsd::apply_config_json(R"({"domian": [1]})", c);
    FAIL() << "no error";
  } catch (const rsd::ConfigError& e) {
    const std::string message = e.what();
    // Where it is (line and column, as an editor jumps), and the key it was meant to be.
    EXPECT_EQ(message.rfind("config:1:2: unknown key \"domian\"; did you mean \"domains\"? (known: ", 0), 0u)
        << message;
    EXPECT_EQ(names_in(between(message, "(known: ", ")")), table_file_keys()) << message;
  }
  try {
    rsd::apply_config_json("{\n  \"usb\": true,\n    \"frobnicate\": 1\n}", c);
    FAIL() << "no error";
  } catch (const rsd::ConfigError& e) {
    // Nothing near it: no guess.
    EXPECT_EQ(std::string(e.what()).rfind("config:3:5: unknown key \"frobnicate\" (known: ", 0), 0u) << e.what();
  }
}

TEST(ConfigKeys, HelpNamesEveryFlagAndNoOther) {
  const std::string help = rsd::usage_text();
  const std::string options = between(help, "Options:\n", "\nConfig file keys:");
  ASSERT_FALSE(options.empty());
  std::set<std::string> expected{"config", "check-config", "version", "help"};  // not keys
  for (const auto& k : rsd::config_keys()) {
    expected.insert(k.flag);
    // The flag begins its own line, after its short form if it has one.
    const std::string line = k.short_flag ? std::string("\n  -") + k.short_flag + ", --" + k.flag
                                          : std::string("\n      --") + k.flag;
    const auto at = options.find(line);
    EXPECT_TRUE(at != std::string::npos && std::string(" \n").find(options[at + line.size()]) != std::string::npos)
        << k.flag;
  }
  std::set<std::string> named;
  const std::regex flag("--([a-z][a-z-]*)");
  for (auto it = std::sregex_iterator(options.begin(), options.end(), flag); it != std::sregex_iterator(); ++it)
    named.insert((*it)[1].str());
  EXPECT_EQ(named, expected);
}

TEST(ConfigKeys, HelpNamesEveryFileKeyAndWhatReloadApplies) {
  const std::string help = rsd::usage_text();
  EXPECT_EQ(names_in(between(help, "Config file keys:", "; otherwise")), table_file_keys());
  std::set<std::string> live;
  for (const auto& k : rsd::config_keys())
    if (k.reload == rsd::Reload::live) live.insert(k.file);
  EXPECT_EQ(names_in(between(help, "SIGHUP applies", "; the other keys take")), live);
}

namespace {

// Every option daemon_options() sets, as one text to compare.
std::string options_text(const rsd::DaemonOptions& o) {
  std::ostringstream out;
  const auto list = [&](const auto& values) {
    for (const auto& v : values) out << v << ',';
    out << ';';
  };
  out << static_cast<int>(o.log_level) << ';' << o.usb << ';';
  list(o.domains);
  const auto& s = o.session;
  out << s.participant_name << ';' << s.cyclone_config << ';' << s.interfaces_from_cyclone_config << ';'
      << s.book.max_devices_per_participant << ';' << s.book.max_devices_per_domain << ';'
      << s.book.max_writers_per_participant << ';' << s.book.max_writers_per_domain << ';'
      << s.describe_timeout.count() << ';' << s.book.removal_grace.count() << ';' << s.describe_eagerly << ';' << s.share.share << ';';
  list(s.describe_eagerly_in);
  list(o.interfaces.include);
  list(o.interfaces.exclude);
  const auto& a = o.api;
  out << a.unix_socket << ';' << a.unix_socket_gid << ';' << a.http_host << ';' << a.http_port << ';' << a.http_configured << ';'
      << a.max_connections << ';';
  list(a.allowed_hosts);
  for (const auto& e : o.expected) out << e.name << '=' << e.key() << ',';
  return out.str();
}

}  // namespace

TEST(DaemonOptions, EveryKeyReachesAnOptionOfTheDaemonsParts) {
  const std::string defaults = options_text(rsd::daemon_options(Config{}, ""));
  for (const auto& k : rsd::config_keys()) {
    const std::string key = k.file;
    Config c;
    rsd::apply_config_json("{\"" + key + "\": " + samples().at(key).json + "}", c);
    EXPECT_NE(options_text(rsd::daemon_options(c, "")), defaults) << key << " reaches none of the options";
  }
}

TEST(DaemonOptions, EachValueLandsWhereItsPartReadsIt) {
  Config c;
  rsd::apply_config_json(R"({"domains": [3, 7], "usb": false, "log-level": "debug", "socket": "/tmp/s.sock",
      "http": "[::1]:9002", "allowed-hosts": ["a.example"], "max-clients": 64, "participant-name": "p",
      "interfaces": ["eth1"], "exclude-interfaces": ["eth9"], "max-devices-per-participant": 16,
      "max-devices-per-domain": 64, "max-writers-per-participant": 7, "max-writers-per-domain": 6,
      "describe-timeout": 5, "describe-eagerly": [0, 5], "share-usb": true, "removal-grace": 7})",
                         c);
  const auto o = rsd::daemon_options(c, "");
  EXPECT_EQ(o.domains, (std::vector<int>{3, 7}));
  EXPECT_FALSE(o.usb);
  EXPECT_EQ(o.log_level, rsd::log::Level::debug);
  EXPECT_EQ(o.session.participant_name, "p");
  EXPECT_EQ(o.session.book.max_devices_per_participant, 16u);
  EXPECT_EQ(o.session.book.max_devices_per_domain, 64u);
  EXPECT_EQ(o.session.book.max_writers_per_participant, 7u);
  EXPECT_EQ(o.session.book.max_writers_per_domain, 6u);
  EXPECT_EQ(o.session.describe_timeout, std::chrono::seconds(5));
  EXPECT_EQ(o.session.book.removal_grace, std::chrono::seconds(7));
  EXPECT_FALSE(o.session.describe_eagerly);
  EXPECT_EQ(o.session.describe_eagerly_in, (std::set<int>{0, 5}));
  EXPECT_TRUE(o.session.share.share);
  EXPECT_EQ(o.interfaces.include, std::vector<std::string>{"eth1"});
  EXPECT_EQ(o.interfaces.exclude, std::vector<std::string>{"eth9"});
  EXPECT_EQ(o.api.unix_socket, "/tmp/s.sock");
  EXPECT_EQ(o.api.http_host, "::1");
  EXPECT_EQ(o.api.http_port, 9002);
  EXPECT_TRUE(o.api.http_configured);
  EXPECT_EQ(o.api.allowed_hosts, std::vector<std::string>{"a.example"});
  EXPECT_EQ(o.api.max_connections, 64u);
}

TEST(DaemonOptions, InterfacesNamedByTheCycloneConfigurationAreNotFollowed) {
  const std::string names = R"(<General><Interfaces><NetworkInterface name="eth0"/></Interfaces></General>)";
  Config c;
  EXPECT_FALSE(rsd::daemon_options(c, "").session.interfaces_from_cyclone_config);
  // $CYCLONEDDS_URI counts while the configuration has no cyclonedds-config ...
  EXPECT_TRUE(rsd::daemon_options(c, names).session.interfaces_from_cyclone_config);
  // ... and the option, when set, is what Cyclone DDS is given instead.
  c.cyclonedds_config = "<General/>";
  EXPECT_FALSE(rsd::daemon_options(c, names).session.interfaces_from_cyclone_config);
  c.cyclonedds_config = names;
  EXPECT_TRUE(rsd::daemon_options(c, "").session.interfaces_from_cyclone_config);
}
