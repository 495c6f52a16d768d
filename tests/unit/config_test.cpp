#include "config/config.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <vector>

using rsd::CommandAction;
using rsd::Config;
using rsd::ConfigError;

namespace {
rsd::CommandLine parse(std::vector<const char*> args) {
  args.insert(args.begin(), "rs-discoveryd");
  return rsd::parse_command_line(static_cast<int>(args.size()), args.data());
}
}  // namespace

TEST(Config, EmbeddedDefaults) {
  // The struct's own values, not parse({}): a machine with the package
  // installed has /etc/rs-discoveryd/config.json, which parse() would read.
  const Config c;
  EXPECT_EQ(c.domains, (std::vector<int>{0}));
  EXPECT_EQ(c.http_host, "127.0.0.1");
  EXPECT_EQ(c.http_port, rsd::kDefaultHttpPort);
  EXPECT_TRUE(c.usb);
  EXPECT_EQ(c.log_level, "info");
}

TEST(Config, FlagsParse) {
  auto cl = parse({"--domain", "5", "-d", "232", "--socket", "/tmp/x.sock", "--http", "0.0.0.0:9000",
                   "--no-usb", "--participant-name", "bench", "--log-level", "debug"});
  const Config& c = cl.config;
  EXPECT_EQ(c.domains, (std::vector<int>{5, 232}));
  EXPECT_EQ(c.socket_path, "/tmp/x.sock");
  EXPECT_EQ(c.http_host, "0.0.0.0");
  EXPECT_EQ(c.http_port, 9000);
  EXPECT_FALSE(c.usb);
  EXPECT_EQ(c.participant_name, "bench");
  EXPECT_EQ(c.log_level, "debug");
}

TEST(Config, OffAndIpv6) {
  auto c = parse({"--http", "off"}).config;
  EXPECT_TRUE(c.http_host.empty());
  c = parse({"--http=[::1]:8035", "--socket=off"}).config;
  EXPECT_EQ(c.http_host, "::1");
  EXPECT_TRUE(c.socket_path.empty());
  EXPECT_THROW(parse({"--http", "off", "--socket", "off"}), ConfigError);
}

TEST(Config, BadValuesAreClearErrors) {
  for (std::vector<const char*> args :
       {std::vector<const char*>{"--domain", "233"}, {"--domain", "-1"}, {"--domain", "x"}, {"--domain"},
        {"--http", "localhost"}, {"--http", "h:0"}, {"--http", "h:70000"}, {"--log-level", "loud"},
        {"--frobnicate"}, {"--socket", ""}}) {
    EXPECT_THROW(parse(args), ConfigError) << args[0];
  }
  try {
    parse({"--domain", "300"});
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("0 to 232"), std::string::npos) << e.what();
  }
}

TEST(Config, HelpAndVersion) {
  EXPECT_EQ(parse({"--help"}).action, CommandAction::help);
  EXPECT_EQ(parse({"-V"}).action, CommandAction::version);
}

TEST(Config, FileThenFlagsWin) {
  const std::string path = ::testing::TempDir() + "/rsd-config-test.json";
  std::ofstream(path) << R"({"domains":[1,2],"http":"127.0.0.1:9001","usb":false,)"
                         R"("participant-name":"from-file","cyclonedds-config":"<CycloneDDS/>"})";
  auto c = parse({"--config", path.c_str(), "--domain", "3"}).config;
  EXPECT_EQ(c.domains, (std::vector<int>{3}));
  EXPECT_EQ(c.http_port, 9001);
  EXPECT_FALSE(c.usb);
  EXPECT_EQ(c.participant_name, "from-file");
  EXPECT_EQ(c.cyclonedds_config, "<CycloneDDS/>");
  EXPECT_EQ(c.config_file, path);
}

TEST(Config, BadFilesAreClearErrors) {
  EXPECT_THROW(parse({"--config", "/nonexistent/rs-discoveryd.json"}), ConfigError);
  const std::string path = ::testing::TempDir() + "/rsd-config-bad.json";
  for (const char* text : {"{", "[]", R"({"domains":[]})", R"({"domains":[999]})", R"({"domain":[1]})",
                           R"({"usb":"yes"})", R"({"http":5})"}) {
    std::ofstream(path) << text;
    EXPECT_THROW(parse({"--config", path.c_str()}), ConfigError) << text;
  }
}

TEST(Config, DefaultSocketPathFollowsRuntimeDirectory) {
  setenv("RUNTIME_DIRECTORY", "/run/rs-discoveryd:/run/other", 1);
  EXPECT_EQ(rsd::default_socket_path(), "/run/rs-discoveryd/api.sock");
  unsetenv("RUNTIME_DIRECTORY");
}

TEST(Config, DeviceCaps) {
  const Config defaults;
  EXPECT_EQ(defaults.max_devices_per_participant, 128u);
  EXPECT_EQ(defaults.max_devices_per_domain, 1024u);
  const std::string path = ::testing::TempDir() + "/rsd-config-caps.json";
  std::ofstream(path) << R"({"max-devices-per-participant": 99})";  // flags win over it
  auto cl = parse({"--config", path.c_str(), "--max-devices-per-participant", "8", "--max-devices-per-domain=64"});
  EXPECT_EQ(cl.config.max_devices_per_participant, 8u);
  EXPECT_EQ(cl.config.max_devices_per_domain, 64u);
  Config c;
  rsd::apply_config_json(R"({"max-devices-per-participant": 16, "max-devices-per-domain": 2048})", c);
  EXPECT_EQ(c.max_devices_per_participant, 16u);
  EXPECT_EQ(c.max_devices_per_domain, 2048u);
  for (const char* bad : {R"({"max-devices-per-domain": 0})", R"({"max-devices-per-domain": "many"})",
                          R"({"max-devices-per-participant": -3})", R"({"max-devices-per-participant": 1.5})"}) {
    Config x;
    EXPECT_THROW(rsd::apply_config_json(bad, x), ConfigError) << bad;
  }
  EXPECT_THROW(parse({"--max-devices-per-participant", "lots"}), ConfigError);
}

TEST(Config, WriterCaps) {
  const Config defaults;
  EXPECT_EQ(defaults.max_writers_per_participant, 256u);
  EXPECT_EQ(defaults.max_writers_per_domain, 2048u);
  const std::string path = ::testing::TempDir() + "/rsd-config-writer-caps.json";
  std::ofstream(path) << R"({"max-writers-per-participant": 99, "max-writers-per-domain": 5000})";
  auto cl = parse({"--config", path.c_str(), "--max-writers-per-participant", "8"});  // flags win over the file
  EXPECT_EQ(cl.config.max_writers_per_participant, 8u);
  EXPECT_EQ(cl.config.max_writers_per_domain, 5000u);
  EXPECT_EQ(parse({"--max-writers-per-domain=64"}).config.max_writers_per_domain, 64u);
  for (const char* bad : {R"({"max-writers-per-domain": 0})", R"({"max-writers-per-participant": "all"})"}) {
    Config x;
    EXPECT_THROW(rsd::apply_config_json(bad, x), ConfigError) << bad;
  }
  EXPECT_THROW(parse({"--max-writers-per-domain", "-1"}), ConfigError);
}

TEST(Config, DescribeTimeout) {
  EXPECT_EQ(Config{}.describe_timeout_s, 30);
  Config c;
  rsd::apply_config_json(R"({"describe-timeout": 5})", c);
  EXPECT_EQ(c.describe_timeout_s, 5);
  for (const char* bad : {R"({"describe-timeout": 0})", R"({"describe-timeout": 301})", R"({"describe-timeout": "5"})"}) {
    Config x;
    EXPECT_THROW(rsd::apply_config_json(bad, x), ConfigError) << bad;
  }
}

TEST(Config, DescribeEagerly) {
  Config c;
  EXPECT_FALSE(c.describe_eagerly_all);
  rsd::apply_config_json(R"({"describe-eagerly": [0, 5]})", c);
  EXPECT_EQ(c.describe_eagerly, (std::vector<int>{0, 5}));
  rsd::apply_config_json(R"({"describe-eagerly": true})", c);
  EXPECT_TRUE(c.describe_eagerly_all);
  EXPECT_TRUE(c.describe_eagerly.empty());
  for (const char* bad : {R"({"describe-eagerly": "yes"})", R"({"describe-eagerly": [300]})"}) {
    Config x;
    EXPECT_THROW(rsd::apply_config_json(bad, x), ConfigError) << bad;
  }
}

TEST(Config, AllowedHostsAndMaxClients) {
  const Config defaults;
  EXPECT_TRUE(defaults.allowed_hosts.empty());
  EXPECT_EQ(defaults.max_clients, 4096u);
  Config c;
  rsd::apply_config_json(R"({"allowed-hosts": ["cams.lab.example", "*"], "max-clients": 200})", c);
  EXPECT_EQ(c.allowed_hosts, (std::vector<std::string>{"cams.lab.example", "*"}));
  EXPECT_EQ(c.max_clients, 200u);
  auto cl = parse({"--allowed-host", "a.example", "--allowed-host=b.example:8035", "--max-clients", "64"});
  EXPECT_EQ(cl.config.allowed_hosts, (std::vector<std::string>{"a.example", "b.example:8035"}));
  EXPECT_EQ(cl.config.max_clients, 64u);
  for (const char* bad : {R"({"allowed-hosts": "a.example"})", R"({"allowed-hosts": [""]})",
                          R"({"allowed-hosts": ["http://a.example/"]})", R"({"allowed-hosts": [3]})",
                          R"({"max-clients": 0})", R"({"max-clients": "many"})"}) {
    Config x;
    EXPECT_THROW(rsd::apply_config_json(bad, x), ConfigError) << bad;
  }
  EXPECT_THROW(parse({"--allowed-host", "has space"}), ConfigError);
}

TEST(Config, ANumberTooLargeIsAConfigErrorNotACrash) {
  // Found by fuzz_config: nlohmann's out_of_range escaped as is, and a reload with such
  // a file ended the daemon (Service::reload catches ConfigError).
  Config c;
  EXPECT_THROW(rsd::apply_config_json(R"({"max-devices-per-domain": 64e44444444444444444444})", c), ConfigError);
  EXPECT_THROW(rsd::apply_config_json(R"({"domains": [1e999]})", c), ConfigError);
}
