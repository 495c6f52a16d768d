#include "api/format.hpp"
#include "api/listener.hpp"
#include "api/process_stats.hpp"
#include "status/reasons.hpp"

#include <gtest/gtest.h>

#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

using namespace rsd::api;
using nlohmann::json;

namespace {
// The filter reads typed devices (the table's entries); these tests write documents.
bool matches(const DeviceFilter& f, const json& doc) { return f.matches(rsd::model::device_from_json(doc)); }
}  // namespace

TEST(ApiFilter, EmptyQueryMatchesEverything) {
  DeviceFilter f;
  EXPECT_FALSE(parse_device_filter({}, f));
  EXPECT_TRUE(f.empty());
  EXPECT_TRUE(matches(f, json{{"id", "x"}}));
}

TEST(ApiFilter, DomainIsStrict) {
  for (const char* bad : {"", "-1", "233", "1x", " 1", "+1", "0x1", "1.0", "99999999999999999999", "0001"}) {
    DeviceFilter f;
    EXPECT_TRUE(parse_device_filter({{"domain", bad}}, f)) << bad;
  }
  DeviceFilter f;
  ASSERT_FALSE(parse_device_filter({{"domain", "0"}, {"domain", "232"}}, f));
  EXPECT_EQ(f.domains, (std::set<int>{0, 232}));
  EXPECT_TRUE(matches(f, json{{"domain", 232}}));
  EXPECT_FALSE(matches(f, json{{"domain", 7}}));
  EXPECT_FALSE(matches(f, json{{"domain", "0"}}));  // a string is not the domain
  EXPECT_FALSE(matches(f, json{{"id", "usb-1"}}));  // no domain at all
}

TEST(ApiFilter, ProductLineIgnoresCase) {
  DeviceFilter f;
  ASSERT_FALSE(parse_device_filter({{"product-line", "d400"}}, f));
  EXPECT_TRUE(matches(f, json{{"product-line", "D400"}}));
  EXPECT_FALSE(matches(f, json{{"product-line", "D500"}}));
  EXPECT_FALSE(matches(f, json{{"product-line", 400}}));
  DeviceFilter empty;
  EXPECT_TRUE(parse_device_filter({{"product-line", ""}}, empty));
}

TEST(ApiFilter, SourceMatchesSourceOrSources) {
  DeviceFilter f;
  ASSERT_FALSE(parse_device_filter({{"source", "usb"}}, f));
  EXPECT_TRUE(matches(f, json{{"source", "usb"}}));
  EXPECT_TRUE(matches(f, json{{"sources", {"dds", "usb"}}}));
  EXPECT_FALSE(matches(f, json{{"source", "dds"}, {"sources", {"dds"}}}));
  DeviceFilter bad;
  EXPECT_TRUE(parse_device_filter({{"source", "ethernet"}}, bad));
}

TEST(ApiFilter, SerialNameAndAddress) {
  const json d455 = {{"name", "Intel RealSense D455"}, {"serial", "123622270732"}, {"source", "dds"},
                     {"server", {{"addresses", {"192.0.2.2", "10.0.0.5"}}}}};
  const json usb = {{"name", "Intel RealSense D435"}, {"serial", "ab12"}, {"source", "usb"}};
  DeviceFilter serial;
  ASSERT_FALSE(parse_device_filter({{"serial", "AB12"}}, serial));
  EXPECT_TRUE(matches(serial, usb));
  EXPECT_FALSE(matches(serial, d455));
  DeviceFilter name;  // a part of the name, any case; repeated: either
  ASSERT_FALSE(parse_device_filter({{"name", "d455"}, {"name", "L515"}}, name));
  EXPECT_TRUE(matches(name, d455));
  EXPECT_FALSE(matches(name, usb));
  DeviceFilter address;
  ASSERT_FALSE(parse_device_filter({{"address", "10.0.0.5"}}, address));
  EXPECT_TRUE(matches(address, d455));
  EXPECT_FALSE(matches(address, usb));  // no server, no address
  DeviceFilter partial;  // an address is whole, not a prefix
  ASSERT_FALSE(parse_device_filter({{"address", "10.0.0"}}, partial));
  EXPECT_FALSE(matches(partial, d455));
  for (const char* key : {"serial", "name", "address"}) {
    DeviceFilter empty;
    EXPECT_TRUE(parse_device_filter({{key, ""}}, empty)) << key;
  }
}

TEST(ApiFilter, KeysAndTogetherValuesOr) {
  DeviceFilter f;
  ASSERT_FALSE(parse_device_filter({{"domain", "1"}, {"domain", "2"}, {"source", "dds"}}, f));
  EXPECT_TRUE(matches(f, json{{"domain", 2}, {"source", "dds"}}));
  EXPECT_FALSE(matches(f, json{{"domain", 2}, {"source", "usb"}}));
  EXPECT_FALSE(matches(f, json{{"domain", 3}, {"source", "dds"}}));
}

TEST(ApiFilter, UnknownKeyIsAnErrorUnlessAllowed) {
  DeviceFilter f;
  auto err = parse_device_filter({{"domian", "1"}}, f);
  ASSERT_TRUE(err);
  EXPECT_NE(err->find("domian"), std::string::npos);
  DeviceFilter g;
  EXPECT_FALSE(parse_device_filter({{"since", "5"}}, g, {"since"}));
}

TEST(ApiFields, NamesAreListedDottedAndJoined) {
  DeviceFields f;
  ASSERT_FALSE(parse_device_fields({}, f));
  EXPECT_TRUE(f.whole());
  ASSERT_FALSE(parse_device_fields({{"fields", "name,server.addresses"}, {"fields", "fw-version,name,usb_x"}}, f));
  using Path = std::vector<std::string>;
  EXPECT_EQ(f.paths, (std::vector<Path>{{"name"}, {"server", "addresses"}, {"fw-version"}, {"usb_x"}}));
  DeviceFields many;
  std::string names;
  for (int i = 0; i < 32; ++i) names += (i ? ",k" : "k") + std::to_string(i);
  EXPECT_FALSE(parse_device_fields({{"fields", names}}, many));
  EXPECT_TRUE(parse_device_fields({{"fields", names + ",k32"}}, many));
}

TEST(ApiFields, MalformedIsAnError) {
  for (const char* bad : {"", ",", "a,,b", ",a", "a,", "a..b", ".a", "a.", "a b", "a/b", "\xc3\xa4"}) {
    DeviceFields f;
    const auto err = parse_device_fields({{"fields", bad}}, f);
    ASSERT_TRUE(err) << bad;
    EXPECT_NE(err->find("fields"), std::string::npos) << *err;
  }
  DeviceFields f;
  EXPECT_TRUE(parse_device_fields({{"fields", std::string(65, 'a')}}, f));
  DeviceFilter filter;  // the filter's own check lets it through only when told to
  EXPECT_TRUE(parse_device_filter({{"fields", "name"}}, filter));
  EXPECT_FALSE(parse_device_filter({{"fields", "name"}}, filter, {"fields"}));
}

TEST(ApiFields, ProjectionKeepsTheIdAndTheNamedKeys) {
  const json doc = {{"id", "dds-1-x"},
                    {"name", "Intel RealSense D455"},
                    {"serial", "1"},
                    {"server", {{"addresses", {"192.0.2.2"}}, {"participant-guid", "g"}}},
                    {"usb", nullptr}};
  const auto project = [&](const std::string& names) {
    DeviceFields f;
    EXPECT_FALSE(parse_device_fields({{"fields", names}}, f));
    return json::parse(project_device(dump(doc), f));
  };
  EXPECT_EQ(project("serial,server.addresses"),
            (json{{"id", "dds-1-x"}, {"serial", "1"}, {"server", {{"addresses", {"192.0.2.2"}}}}}));
  EXPECT_EQ(project("server.addresses,server"), (json{{"id", "dds-1-x"}, {"server", doc["server"]}}));
  EXPECT_EQ(project("server,server.addresses"), (json{{"id", "dds-1-x"}, {"server", doc["server"]}}));
  // Absent, or not an object on the way: left out. A null is a value like any.
  EXPECT_EQ(project("host,name.first,server.nothing,usb"), (json{{"id", "dds-1-x"}, {"usb", nullptr}}));
  // Spelled as the whole document is (dump: one line, keys sorted).
  DeviceFields all;
  ASSERT_FALSE(parse_device_fields({{"fields", "name,serial,server,usb"}}, all));
  EXPECT_EQ(project_device(dump(doc), all), dump(doc));
}

TEST(ApiParse, Generation) {
  EXPECT_EQ(parse_generation("0"), 0u);
  EXPECT_EQ(parse_generation("18446744073709551615"), UINT64_MAX);
  EXPECT_FALSE(parse_generation("18446744073709551616"));
  EXPECT_FALSE(parse_generation(""));
  EXPECT_FALSE(parse_generation("-1"));
  EXPECT_FALSE(parse_generation("12 "));
  EXPECT_FALSE(parse_generation("abc"));
}

TEST(ApiSse, MessageFraming) {
  EXPECT_EQ(sse_message("added", 7, R"({"id":"a"})"), "event: added\nid: 7\ndata: {\"id\":\"a\"}\n\n");
  EXPECT_EQ(sse_message("", std::nullopt, "x"), "data: x\n\n");
  // A line break inside data must not end the event early or forge a field.
  EXPECT_EQ(sse_message("m", 1, "a\nevent: evil\r\nb\rc"),
            "event: m\nid: 1\ndata: a\ndata: event: evil\ndata: b\ndata: c\n\n");
  EXPECT_EQ(sse_message("m", 1, ""), "event: m\nid: 1\ndata: \n\n");
}

TEST(ApiSse, CommentIsOneLine) {
  EXPECT_EQ(sse_comment("keep-alive"), ": keep-alive\n\n");
  EXPECT_EQ(sse_comment("a\nb"), ": a b\n\n");
}

TEST(ApiJson, DumpIsOneLineAndSurvivesBadUtf8) {
  json doc = {{"name", std::string("bad \xff utf8")}, {"nl", "a\nb"}};
  std::string out;
  ASSERT_NO_THROW(out = dump(doc));
  EXPECT_EQ(out.find('\n'), std::string::npos);
  EXPECT_TRUE(json::accept(out));
}

TEST(ApiJson, ErrorBody) {
  auto body = json::parse(error_body(404, "no device with id 'x'"));
  EXPECT_EQ(body["status"], 404);
  EXPECT_EQ(body["error"], "no device with id 'x'");
}

// /v1/domains and /metrics show a domain's state by the names openapi.yaml lists.
TEST(ApiJson, DomainStateNames) {
  using rsd::DomainState;
  const std::pair<DomainState, const char*> names[] = {{DomainState::settling, "settling"},
                                                      {DomainState::running, "running"},
                                                      {DomainState::rebuilding, "rebuilding"},
                                                      {DomainState::failed, "failed"},
                                                      {DomainState::stopped, "stopped"}};
  for (const auto& [state, name] : names) {
    rsd::DomainStatus s;
    s.state = state;
    EXPECT_EQ(domain_status_json(s)["state"], name);
    EXPECT_EQ(rsd::parse_domain_state(name), state);
  }
  EXPECT_EQ(rsd::parse_domain_state("Running"), std::nullopt);
  EXPECT_EQ(rsd::DomainStatus{}.state, DomainState::stopped);
}

TEST(ApiJson, DomainStatus) {
  rsd::DomainStatus s;
  s.domain = 5;
  s.state = rsd::DomainState::running;
  s.participant_guid = "01.02";
  s.devices = 2;
  s.accepted = 10;
  s.rejected = {{"not-json", 3}};
  auto j = domain_status_json(s);
  EXPECT_EQ(j["domain"], 5);
  EXPECT_EQ(j["participant-guid"], "01.02");
  EXPECT_EQ(j["rejected"]["not-json"], 3);
  EXPECT_TRUE(domain_status_json(rsd::DomainStatus{})["rejected"].is_object());
  EXPECT_EQ(j["complete"], false);  // the first discovery is not over until DDS says so
  s.complete = true;
  EXPECT_EQ(domain_status_json(s)["complete"], true);
}

TEST(ApiMetrics, LabelEscaping) {
  EXPECT_EQ(prometheus_label_value("a\"b\\c\nd"), "a\\\"b\\\\c\\nd");
}

TEST(ApiMetrics, Exposition) {
  MetricsInput in;
  in.version = "1.2.3";
  rsd::DomainStatus d0;
  d0.domain = 0;
  d0.state = rsd::DomainState::running;
  d0.accepted = 4;
  d0.rejected = {{"bad-cbor", 2}, {"not-json", 1}};
  rsd::DomainStatus d9;
  d9.domain = 9;
  d9.state = rsd::DomainState::failed;
  in.domains = {d0, d9};
  in.devices_per_domain = {{0, 3}};
  in.devices_total = 3;
  in.events_sent = 11;
  in.requests_by_status = {{200, 5}, {404, 1}};
  const std::string text = render_metrics(in);
  for (const char* line :
       {"rsd_domain_devices{domain=\"0\"} 3\n", "rsd_domain_devices{domain=\"9\"} 0\n",
        "rsd_devices{domain=\"0\"} 3\n", "rsd_devices{domain=\"9\"} 0\n", "rsd_messages_accepted_total{domain=\"0\"} 4\n",
        "rsd_messages_rejected_total{domain=\"0\",reason=\"bad-cbor\"} 2\n", "rsd_events_sent_total 11\n",
        "rsd_api_requests_total{status=\"404\"} 1\n", "rsd_domain_up{domain=\"9\",state=\"failed\"} 0\n",
        "# TYPE rsd_messages_rejected_total counter\n", "# TYPE rsd_domain_devices gauge\n",
        "rsd_build_info{version=\"1.2.3\"} 1\n", "rsd_table_complete 0\n"})
    EXPECT_NE(text.find(line), std::string::npos) << line << "\nin:\n" << text;
  // Complete once every domain is; no domains: nothing to wait for.
  for (auto& d : in.domains) d.complete = true;
  EXPECT_NE(render_metrics(in).find("rsd_table_complete 1\n"), std::string::npos);
  EXPECT_NE(render_metrics(MetricsInput{}).find("rsd_table_complete 1\n"), std::string::npos);
  // Every sample's family is declared before it, once.
  std::set<std::string> declared;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("# TYPE ", 0) == 0) {
      auto name = line.substr(7, line.find(' ', 7) - 7);
      EXPECT_TRUE(declared.insert(name).second) << name;
    } else if (line.rfind("#", 0) != 0) {
      auto name = line.substr(0, line.find_first_of("{ "));
      EXPECT_TRUE(declared.contains(name)) << line;
    }
  }
}

namespace {
std::string temp_socket_path(const char* tag) {
  return (std::filesystem::temp_directory_path() / ("rsd-api-test-" + std::to_string(getpid()) + "-" + tag)).string();
}
int bind_unix(const std::string& path, bool listen_too) {
  int fd = socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::snprintf(a.sun_path, sizeof a.sun_path, "%s", path.c_str());
  if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return -1;
  if (listen_too) listen(fd, 1);
  return fd;
}
}  // namespace

TEST(ApiSocketPath, MissingIsFine) {
  const auto path = temp_socket_path("missing");
  std::filesystem::remove(path);
  EXPECT_NO_THROW(prepare_unix_socket_path(path));
}

TEST(ApiSocketPath, StaleSocketIsReplaced) {
  const auto path = temp_socket_path("stale");
  std::filesystem::remove(path);
  int fd = bind_unix(path, false);  // bound but never listening: what a crash leaves behind
  ASSERT_GE(fd, 0);
  close(fd);
  ASSERT_TRUE(std::filesystem::exists(path));
  EXPECT_NO_THROW(prepare_unix_socket_path(path));
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(ApiSocketPath, LiveSocketIsRefused) {
  const auto path = temp_socket_path("live");
  std::filesystem::remove(path);
  int fd = bind_unix(path, true);
  ASSERT_GE(fd, 0);
  try {
    prepare_unix_socket_path(path);
    ADD_FAILURE() << "a live socket was taken over";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("already running"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(std::filesystem::exists(path));
  close(fd);
  std::filesystem::remove(path);
}

TEST(ApiSocketPath, RegularFileIsLeftAlone) {
  const auto path = temp_socket_path("file");
  { std::ofstream(path) << "not a socket"; }
  EXPECT_THROW(prepare_unix_socket_path(path), std::runtime_error);
  EXPECT_TRUE(std::filesystem::exists(path));
  std::filesystem::remove(path);
  EXPECT_THROW(prepare_unix_socket_path(std::string(200, 'x')), std::runtime_error);
}

TEST(ApiMetrics, ProcessFiguresUnderTheirUsualNames) {
  const auto process = rsd::api::read_process_stats();  // this test's own process
  ASSERT_TRUE(process);
  EXPECT_GT(process->resident_bytes, 1'000'000u);
  EXPECT_GE(process->virtual_bytes, process->resident_bytes);
  EXPECT_GE(process->open_fds, 3u);  // stdin, stdout, stderr at least
  EXPECT_GE(process->max_fds, process->open_fds);
  EXPECT_GT(process->start_time_seconds, 1.7e9);  // after 2023, before now
  EXPECT_LE(process->start_time_seconds, static_cast<double>(std::time(nullptr)) + 1);
  MetricsInput in;
  in.process = rsd::api::ProcessStats{1.5, 4096, 8192, 7, 1024, 1.75e9};
  const std::string text = render_metrics(in);
  for (const char* line : {"# TYPE process_cpu_seconds_total counter\n", "process_cpu_seconds_total 1.500000\n",
                           "process_resident_memory_bytes 4096\n", "process_virtual_memory_bytes 8192\n",
                           "process_open_fds 7\n", "process_max_fds 1024\n",
                           "process_start_time_seconds 1750000000.000000\n"})
    EXPECT_NE(text.find(line), std::string::npos) << line;
  EXPECT_EQ(render_metrics(MetricsInput{}).find("process_"), std::string::npos);  // none when /proc is not there
}

// A counter that first appears at its first increment is invisible to rate() and
// increase(): every label value the daemon knows is there at 0 from the start.
TEST(ApiMetrics, KnownLabelValuesAreThereAtZero) {
  MetricsInput in;
  rsd::DomainStatus d;
  d.domain = 7;
  d.rejected = {{"notification-not-json", 2}};  // not a known one: still shown
  in.domains = {d};
  in.requests_by_status = {{200, 3}, {418, 1}};
  const std::string text = render_metrics(in);
  for (const char* line : {"rsd_messages_rejected_total{domain=\"7\",reason=\"not-json\"} 0\n",
                           "rsd_messages_rejected_total{domain=\"7\",reason=\"missing-topic-root\"} 0\n",
                           "rsd_messages_rejected_total{domain=\"7\",reason=\"domain-device-limit\"} 0\n",
                           "rsd_messages_rejected_total{domain=\"7\",reason=\"refused-writer\"} 0\n",
                           "rsd_messages_rejected_total{domain=\"7\",reason=\"notification-not-json\"} 2\n",
                           "rsd_writers_refused_total{domain=\"7\",reason=\"domain-writer-limit\"} 0\n",
                           "rsd_endpoints_refused_total{domain=\"7\",reason=\"topic-name-too-long\"} 0\n",
                           "rsd_endpoints_refused_total{domain=\"7\",reason=\"participant-endpoint-limit\"} 0\n",
                           "rsd_api_requests_total{status=\"200\"} 3\n", "rsd_api_requests_total{status=\"404\"} 0\n",
                           "rsd_api_requests_total{status=\"503\"} 0\n", "rsd_api_requests_total{status=\"418\"} 1\n"})
    EXPECT_NE(text.find(line), std::string::npos) << line << "\nin:\n" << text;
  for (const char* reason : rsd::kParseRejectReasons)
    EXPECT_NE(text.find(std::string("reason=\"") + reason + "\"} 0\n"), std::string::npos) << reason;
}

TEST(ApiMetrics, DeprecatedDeviceGaugeSaysSoAndMatches) {
  MetricsInput in;
  rsd::DomainStatus d;
  d.domain = 3;
  in.domains = {d};
  in.devices_per_domain = {{3, 2}};
  const std::string text = render_metrics(in);
  EXPECT_NE(text.find("# HELP rsd_devices Deprecated"), std::string::npos) << text;
  EXPECT_NE(text.find("rsd_domain_devices{domain=\"3\"} 2\n"), std::string::npos) << text;
  EXPECT_NE(text.find("rsd_devices{domain=\"3\"} 2\n"), std::string::npos) << text;
}

// Under socket activation the socket unit's address wins; /healthz "http" says
// whether the configuration names the same one.
TEST(ApiHttpHealth, AgreesUnlessAPassedSocketIsElsewhere) {
  // Bound by the daemon itself: the configured address, always.
  auto h = http_health("127.0.0.1", 8035, true, "127.0.0.1", 8035, false);
  EXPECT_TRUE(h.agrees);
  EXPECT_EQ(h.from, "config");
  EXPECT_EQ(h.listening, "127.0.0.1:8035");
  EXPECT_EQ(h.configured, "127.0.0.1:8035");
  // From systemd, elsewhere: by port, by address, or HTTP configured off.
  h = http_health("127.0.0.1", 8035, true, "127.0.0.1", 8036, true);
  EXPECT_FALSE(h.agrees);
  EXPECT_EQ(h.from, "systemd");
  EXPECT_EQ(h.listening, "127.0.0.1:8036");
  EXPECT_FALSE(http_health("127.0.0.1", 8035, true, "0.0.0.0", 8035, true).agrees);
  EXPECT_FALSE(http_health("127.0.0.1", 8035, true, "::", 8035, true).agrees);
  h = http_health("", 8035, true, "127.0.0.1", 8035, true);
  EXPECT_FALSE(h.agrees);
  EXPECT_EQ(h.configured, "off");
  // The same address however written; a host name by its port; nothing named.
  EXPECT_TRUE(http_health("0:0::1", 8035, true, "::1", 8035, true).agrees);
  EXPECT_EQ(http_health("::1", 8035, true, "::1", 8035, true).listening, "[::1]:8035");
  EXPECT_TRUE(http_health("localhost", 8035, true, "127.0.0.1", 8035, true).agrees);
  EXPECT_FALSE(http_health("localhost", 8035, true, "127.0.0.1", 9000, true).agrees);
  h = http_health("127.0.0.1", 8035, false, "127.0.0.1", 9000, true);
  EXPECT_TRUE(h.agrees);
  EXPECT_EQ(h.configured, "");
  // No HTTP at all.
  h = http_health("", 0, true, "", 0, false);
  EXPECT_TRUE(h.agrees);
  EXPECT_EQ(h.listening, "");
}

TEST(ApiFilter, InUseIsTrueOrFalse) {
  const json used = {{"id", "dds-0-a"}, {"in-use", {{"clients", 1}, {"streaming", json::array()}}}};
  const json idle = {{"id", "dds-0-b"}};
  DeviceFilter yes, no;
  ASSERT_FALSE(parse_device_filter({{"in-use", "true"}}, yes));
  ASSERT_FALSE(parse_device_filter({{"in-use", "FALSE"}}, no));
  EXPECT_FALSE(yes.empty());
  EXPECT_TRUE(matches(yes, used));
  EXPECT_FALSE(matches(yes, idle));
  EXPECT_FALSE(matches(no, used));
  EXPECT_TRUE(matches(no, idle));
  // A malformed "in-use" (a peer's own key) is not the daemon's summary: not in use.
  EXPECT_FALSE(matches(yes, json{{"id", "x"}, {"in-use", true}}));
  for (const char* bad : {"", "1", "yes"}) {
    DeviceFilter f;
    EXPECT_TRUE(parse_device_filter({{"in-use", bad}}, f)) << bad;
  }
  DeviceFilter both;
  EXPECT_TRUE(parse_device_filter({{"in-use", "true"}, {"in-use", "false"}}, both));
}
