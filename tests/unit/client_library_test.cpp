// Unit tests of the rsdiscovery client library: the pure parts (endpoints, SSE
// parsing, documents); requests, watches and subscriptions against the daemon's real
// ApiServer (tests/api/api_harness, a child process fed the table on its
// stdin); and, against a raw stand-in on a Unix socket, the answers the real server
// never gives (malformed replies, another API version, oversized answers).
#include "internal.hpp"
#include "rsd_model/clients.hpp"
#include "rsd_model/device.hpp"
#include "rsd_model/participant.hpp"
#include "rsd_model/status.hpp"
#include "table/device_table.hpp"
#include "usb/usb_device.hpp"

#include <rsdiscovery/rsdiscovery.hpp>

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <linux/sockios.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <charconv>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <future>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <thread>

extern char** environ;

using namespace rsdiscovery;
using namespace std::chrono_literals;
using njson = nlohmann::json;

namespace {
// A document the daemon's side wrote (nlohmann) as the client parses it.
rsdiscovery::json::Document client_doc(const njson& doc) {
  rsdiscovery::json::Document out;
  EXPECT_EQ(rsdiscovery::json::parse(doc.dump(), out), std::nullopt);
  return out;
}
}  // namespace

namespace {

// ---- endpoints --------------------------------------------------------------------------

TEST(Endpoint, ParsesUnixForms) {
  EXPECT_EQ(Endpoint::parse("unix:/run/x.sock").path, "/run/x.sock");
  EXPECT_EQ(Endpoint::parse("unix:///run/x.sock").path, "/run/x.sock");
  EXPECT_EQ(Endpoint::parse("/tmp/a b.sock").path, "/tmp/a b.sock");
  EXPECT_EQ(Endpoint::parse("unix:/run/x.sock").kind, Endpoint::Kind::unix_socket);
  EXPECT_EQ(Endpoint::parse("unix:/run/x.sock").to_string(), "unix:/run/x.sock");
}

TEST(Endpoint, ParsesHttpForms) {
  auto e = Endpoint::parse("http://127.0.0.1:8035");
  EXPECT_EQ(e.kind, Endpoint::Kind::http);
  EXPECT_EQ(e.host, "127.0.0.1");
  EXPECT_EQ(e.port, 8035);
  EXPECT_EQ(Endpoint::parse("http://localhost/").port, 80);  // a URL: its rules
  // host:port, or a bare host on the daemon's default port.
  EXPECT_EQ(Endpoint::parse("camera-pc").to_string(), "http://camera-pc:8035");
  EXPECT_EQ(Endpoint::parse("10.0.0.5:9000").to_string(), "http://10.0.0.5:9000");
  EXPECT_EQ(Endpoint::parse("[::1]").to_string(), "http://[::1]:8035");
  auto v6 = Endpoint::parse("http://[::1]:9000");
  EXPECT_EQ(v6.host, "::1");
  EXPECT_EQ(v6.port, 9000);
  EXPECT_EQ(v6.to_string(), "http://[::1]:9000");
}

TEST(Endpoint, RejectsNonsenseWithAClearMessage) {
  for (const char* bad : {"", "ftp://x", "unix:relative.sock", "http://", "http://h:port", "http://h:70000",
                          "https://h:1", "http://h:1/v1/devices", "http://[::1"}) {
    try {
      Endpoint::parse(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::bad_endpoint) << bad;
      EXPECT_NE(std::string(e.what()).find("bad endpoint"), std::string::npos);
    }
  }
}

struct EnvGuard {
  std::vector<std::pair<std::string, std::optional<std::string>>> saved;
  void set(const char* name, const char* value) {
    const char* old = std::getenv(name);
    saved.emplace_back(name, old ? std::optional<std::string>(old) : std::nullopt);
    if (value)
      setenv(name, value, 1);
    else
      unsetenv(name);
  }
  ~EnvGuard() {
    for (auto it = saved.rbegin(); it != saved.rend(); ++it) {
      if (it->second)
        setenv(it->first.c_str(), it->second->c_str(), 1);
      else
        unsetenv(it->first.c_str());
    }
  }
};

TEST(Endpoint, DefaultFollowsTheDaemonsRule) {
  EnvGuard env;
  env.set("RS_DISCOVERY_ENDPOINT", nullptr);
  env.set("RUNTIME_DIRECTORY", "/run/rs-discoveryd");
  EXPECT_EQ(Endpoint::default_socket().path, "/run/rs-discoveryd/api.sock");
  env.set("RUNTIME_DIRECTORY", nullptr);
  env.set("XDG_RUNTIME_DIR", "/run/user/1234");
  if (geteuid() == 0)
    EXPECT_EQ(Endpoint::default_socket().path, "/run/rs-discoveryd/api.sock");
  else
    EXPECT_EQ(Endpoint::default_socket().path, "/run/user/1234/rs-discoveryd.sock");
  env.set("RS_DISCOVERY_ENDPOINT", "http://127.0.0.1:9999");
  EXPECT_EQ(Endpoint::from_environment().to_string(), "http://127.0.0.1:9999");
  env.set("RS_DISCOVERY_ENDPOINT", "");
  EXPECT_EQ(Endpoint::from_environment().kind, Endpoint::Kind::unix_socket);
  // A bad value names the variable it came from.
  env.set("RS_DISCOVERY_ENDPOINT", "ftp://x");
  try {
    Endpoint::from_environment();
    ADD_FAILURE() << "no error for a bad RS_DISCOVERY_ENDPOINT";
  } catch (const rsdiscovery::Error& e) {
    EXPECT_EQ(e.code(), rsdiscovery::ErrorCode::bad_endpoint);
    EXPECT_EQ(std::string(e.what()).rfind("RS_DISCOVERY_ENDPOINT: bad endpoint 'ftp://x'", 0), 0u) << e.what();
  }
}

// ---- SSE ------------------------------------------------------------------------------------

std::vector<detail::SseMessage> parse_sse(const std::string& text, std::size_t chunk) {
  std::vector<detail::SseMessage> out;
  detail::SseParser p([&](detail::SseMessage&& m) { out.push_back(std::move(m)); });
  for (std::size_t i = 0; i < text.size(); i += chunk) p.feed(std::string_view(text).substr(i, chunk));
  return out;
}

// Feeds `text` `times` times; the code of the Error thrown (cancelled: none).
ErrorCode code_of_sse(detail::SseParser& p, const std::string& text, std::size_t times) {
  try {
    for (std::size_t i = 0; i < times; i++) p.feed(text);
  } catch (const Error& e) {
    return e.code();
  }
  return ErrorCode::cancelled;
}

TEST(Sse, ParsesTheDaemonsStreamInAnyChunking) {
  const std::string stream =
      "retry: 1000\n\n"
      "event: hello\nid: 5\ndata: {\"generation\":5}\n\n"
      ": keep-alive\n\n"
      "event: added\r\nid: 6\r\ndata: {\"id\":\"a\"}\r\n\r\n"
      "event: removed\rid: 7\rdata: line1\rdata: line2\r\r"
      "data:no-space\n\n"
      "event: resync\nid: 9\n\n";
  for (std::size_t chunk : {std::size_t(1), std::size_t(2), std::size_t(3), std::size_t(7), stream.size()}) {
    auto m = parse_sse(stream, chunk);
    ASSERT_EQ(m.size(), 5u) << "chunk " << chunk;
    EXPECT_EQ(m[0].event, "hello");
    EXPECT_EQ(m[0].id, "5");
    EXPECT_EQ(m[1].event, "added");
    EXPECT_EQ(m[1].data, "{\"id\":\"a\"}");
    EXPECT_EQ(m[1].id, "6");
    EXPECT_EQ(m[2].event, "removed");
    EXPECT_EQ(m[2].data, "line1\nline2");
    EXPECT_EQ(m[3].event, "message");
    EXPECT_EQ(m[3].data, "no-space");
    EXPECT_FALSE(m[3].has_id);
    EXPECT_EQ(m[4].event, "resync");
    EXPECT_EQ(m[4].id, "9");
  }
}

TEST(Sse, SkipsALeadingByteOrderMarkAndCountsComments) {
  std::vector<detail::SseMessage> out;
  detail::SseParser p([&](detail::SseMessage&& m) { out.push_back(std::move(m)); });
  p.feed("\xEF\xBB");
  p.feed("\xBF: hi\n\ndata: x\n\n: keep-alive\n");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].data, "x");
  EXPECT_EQ(p.comments(), 2u);
}

TEST(Sse, AnEventBeyondTheBoundIsAnErrorNotAnAllocation) {
  const std::string mib(std::size_t{1} << 20, 'x');
  for (const std::string line_start : {"data: ", ": a comment "}) {  // one line that never ends
    detail::SseParser p([](detail::SseMessage&&) {});
    p.feed(line_start);
    std::size_t fed = 0;
    try {
      while (fed <= detail::kMaxEvent + mib.size()) {
        p.feed(mib);
        fed += mib.size();
      }
      ADD_FAILURE() << "fed " << fed << " bytes of '" << line_start << "' without an error";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::malformed_reply);
      EXPECT_NE(std::string(e.what()).find("larger than 16 MiB"), std::string::npos) << e.what();
      EXPECT_LE(fed, detail::kMaxEvent);
    }
  }
  // Many lines of one event: the event's data is bounded too.
  detail::SseParser p([](detail::SseMessage&&) {});
  const std::string data_line = "data: " + std::string(1000, 'y') + "\n";
  EXPECT_EQ(code_of_sse(p, data_line, detail::kMaxEvent / 1000 + 2), ErrorCode::malformed_reply);
}

// ---- documents -------------------------------------------------------------------------------

TEST(Device, TakesEveryKnownFieldAndKeepsTheDocument) {
  auto d = parse_device(R"({"id":"dds-7-realsense.D455_1","source":"dds","domain":7,
    "topic-root":"realsense/D455_1","name":"Intel RealSense D455","serial":"1","product-line":"D400",
    "product-id":"0B5C","fw-version":"5.16.0.1","recovery":true,"first-seen":"2026-11-23T13:10:20.123Z",
    "last-seen":"2026-11-23T13:10:21.000Z","multicast-ip":"239.0.0.1",
    "server":{"participant-guid":"g","participant-name":"n","addresses":["192.168.1.5","10.0.0.2"]}})");
  EXPECT_EQ(d.id, "dds-7-realsense.D455_1");
  EXPECT_EQ(d.domain, 7);
  EXPECT_EQ(d.sources, std::vector<std::string>{"dds"});
  EXPECT_TRUE(d.recovery);
  ASSERT_TRUE(d.server);
  EXPECT_EQ(d.server->addresses.size(), 2u);
  EXPECT_FALSE(d.usb);
  EXPECT_EQ(d.field("multicast-ip"), "\"239.0.0.1\"");
  EXPECT_EQ(d.field("absent"), "");
  EXPECT_EQ(njson::parse(d.json)["fw-version"], "5.16.0.1");
}

TEST(Device, ListSlicesAreEachDeviceExactlyAsSent) {
  // What Client::list keeps as Device::json: each element of "devices" cut out of
  // the reply, so it must be the element whatever its strings hold.
  njson list = {{"complete", true},
               {"a-before", njson::array({njson::array({1, 2}), "x]", njson::object({{"k", "}"}})})},
               {"devices", njson::array({njson::object({{"id", "a\"b\\"}, {"name", "quote \" [brace] {x}"}}),
                                        njson::object({{"id", "c"}, {"nested", {{"deep", njson::array({1, "2", nullptr})}}}}),
                                        njson::object({{"id", "\\\\"}, {"name", "caf\u00e9 \u2014 \\\""}})})},
               {"generation", 42}};
  list["devices"].push_back({{"id", "d"}, {"devices", njson::array({njson::object({{"id", "inner"}})})}});
  for (const std::string& text : {list.dump(), list.dump(2)}) {  // compact, as the daemon writes, and spaced
    const auto slices = detail::array_member_elements(text, "devices");
    ASSERT_EQ(slices.size(), 4u) << text;
    for (std::size_t i = 0; i < slices.size(); ++i) EXPECT_EQ(njson::parse(slices[i]), list["devices"][i]);
    // The list reader notes the same spans while it parses (the scan is its fallback).
    std::string body = text;
    DeviceList out;
    ASSERT_EQ(detail::read_device_list(body, "/v1/devices", out), std::nullopt) << text;
    ASSERT_EQ(out.devices.size(), 4u);
    for (std::size_t i = 0; i < slices.size(); ++i) EXPECT_EQ(out.devices[i].json, slices[i]) << i;
  }
  EXPECT_EQ(detail::array_member_elements(njson({{"devices", njson::array()}}).dump(), "devices").size(), 0u);
  EXPECT_EQ(detail::array_member_elements(R"({"devices":[1, "two", true, null]})", "devices").size(), 4u);
  EXPECT_TRUE(detail::array_member_elements(R"({"other":[1]})", "devices").empty());
  EXPECT_TRUE(detail::array_member_elements(R"({"devices":{"id":1}})", "devices").empty());
  EXPECT_TRUE(detail::array_member_elements(R"([{"devices":[1]}])", "devices").empty());
  // What is not JSON ends the scan (it runs before the parser has judged the reply).
  for (const char* broken : {R"({"devices":[})", R"({"devices":[1,})", R"({"devices":["abc)", R"({"devices":[{"a":"\"}])",
                             R"({"devices":[,,])", R"({"devices")", R"({"devices":)", R"({"devices":[{)", "{", ""})
    detail::array_member_elements(broken, "devices");
}

// A D435 (a USB 3 camera) on bus 2, port 1.3, as libusb would describe it.
rsd::usb::UsbSighting d435_sighting(std::uint16_t bcd_usb, double speed_mbps) {
  rsd::usb::UsbSighting s;
  s.vid = 0x8086;
  s.pid = 0x0B07;
  s.bcd_usb = bcd_usb;
  s.bus = 2;
  s.address = 5;
  s.ports = {1, 3};
  s.speed_mbps = speed_mbps;
  s.serial = "123";
  return s;
}

// The daemon reads a device with its model (proto/model, on nlohmann), the client with
// its own reader (device_list.cpp, on RapidJSON): every field of the public Device must
// come out as the daemon's reading of the same document has it.
void expect_read_as_the_daemon_reads(const Device& d, const njson& doc) {
  const auto m = rsd::model::device_from_json(doc);
  std::vector<std::string> sources;
  for (auto x : m.sources) sources.push_back(rsd::model::to_string(x));
  std::string source = m.source ? rsd::model::to_string(*m.source) : "";
  if (sources.empty() && !source.empty()) sources.push_back(source);
  if (source.empty() && !sources.empty()) source = sources.front();
  EXPECT_EQ(d.id, m.id);
  EXPECT_EQ(d.source, source);
  EXPECT_EQ(d.sources, sources);
  EXPECT_EQ(d.domain, m.domain);
  EXPECT_EQ(d.topic_root, m.topic_root.value_or(""));
  EXPECT_EQ(d.name, m.name.value_or(""));
  EXPECT_EQ(d.serial, m.serial.value_or(""));
  EXPECT_EQ(d.product_line, m.product_line.value_or(""));
  EXPECT_EQ(d.product_id, m.product_id.value_or(""));
  EXPECT_EQ(d.fw_version, m.fw_version.value_or(""));
  EXPECT_EQ(d.recovery, m.recovery.value_or(false));
  EXPECT_EQ(d.first_seen, m.first_seen.value_or(""));
  EXPECT_EQ(d.last_seen, m.last_seen.value_or(""));
  EXPECT_EQ(d.state, rsd::model::to_string(m.state()));
  EXPECT_EQ(d.warnings, m.warnings);
  EXPECT_EQ(d.warning, m.warnings.empty() ? "" : m.warnings.front());
  ASSERT_EQ(d.server.has_value(), m.server.has_value());
  if (d.server) {
    EXPECT_EQ(d.server->participant_guid, m.server->participant_guid.value_or(""));
    EXPECT_EQ(d.server->participant_name, m.server->participant_name.value_or(""));
    EXPECT_EQ(d.server->addresses, m.server->addresses.value_or(std::vector<std::string>{}));
  }
  ASSERT_EQ(d.usb.has_value(), m.usb.has_value());
  if (d.usb) {
    EXPECT_EQ(d.usb->bus, m.usb->bus);
    EXPECT_EQ(d.usb->port_path, m.usb->port_path);
    EXPECT_EQ(d.usb->speed, m.usb->speed);
  }
  detail::DeviceDocument client;
  const auto unread = detail::read_device(doc.dump(), client);
  ASSERT_TRUE(!unread || unread == detail::Unread::no_id);
  const auto& host = client.host;
  ASSERT_EQ(host.has_value(), m.host.has_value());
  if (host) {
    EXPECT_EQ(host->name, m.host->name);
    EXPECT_EQ(host->addresses, m.host->addresses);
    EXPECT_EQ(host->participant_guid, m.host->participant_guid.value_or(""));
  }
  const auto& in_use = client.in_use;
  ASSERT_EQ(in_use.has_value(), m.in_use.has_value());
  if (in_use) {
    EXPECT_EQ(in_use->clients, m.in_use->clients);
    EXPECT_EQ(in_use->streaming, m.in_use->streaming);
  }
}

TEST(DeviceList, ReadsTheDaemonsListAsTheDaemonReadsEachDevice) {
  // The daemon's own documents: its USB builder and its table, as in the test below.
  auto s = d435_sighting(0x0320, 5000);
  rsd::DeviceTable table;
  table.upsert(rsd::usb::sighting_id(s), rsd::usb::to_json(s, *rsd::usb::find_product(s.vid, s.pid)),
               "2026-11-23T13:10:20.123Z");
  s.serial = "456";
  s.speed_mbps = 480;  // a USB 2 link: a warning
  s.address = 6;
  s.ports = {4};
  table.upsert(rsd::usb::sighting_id(s), rsd::usb::to_json(s, *rsd::usb::find_product(s.vid, s.pid)),
               "2026-11-23T13:10:20.500Z");
  // Device-infos as cameras send them: keys of their own, known keys of other types, a
  // name beyond ASCII (the slower, validating parse), numbers of every kind.
  table.upsert("dds-7-realsense.D455_1",
               {{"source", "dds"}, {"domain", 7}, {"topic-root", "realsense/D455_1"},
                {"name", "Intel RealSense D455 \u2014 caf\u00e9"}, {"serial", "1"}, {"product-line", "D400"},
                {"recovery", true}, {"multicast-ip", "239.0.0.1"}, {"locked", false},
                {"numbers", njson::array({-1, 18446744073709551615ULL, 1.5, 1e300, 0})},
                {"server", {{"participant-guid", "01.0f"}, {"addresses", njson::array({"192.0.2.1", "10.1.2.3"})}}}},
               "2026-11-23T13:10:21.000Z");
  table.upsert("dds-8-realsense.D405_2",
               {{"source", "dds"}, {"domain", "eight"}, {"serial", 2}, {"name", "a \"quoted\" \\ name\n"},
                {"fw-version", nullptr}, {"server", {{"participant-guid", 5}}}, {"warnings", njson::array()}},
               "2026-11-23T13:10:22.000Z");
  // Objects the daemon owns, taken whole or not at all: a key unknown inside one, a
  // required key missing, a count below zero; and a shared camera's host, read whole.
  table.upsert("dds-9-realsense.D555_3",
               {{"source", "remote-usb"}, {"sources", njson::array({"remote-usb", "bluetooth"})},
                {"server", {{"participant-guid", "g"}, {"colour", "red"}}}, {"usb", {{"bus", 1}, {"port-path", "1-2"}}},
                {"in-use", {{"clients", -1}, {"streaming", njson::array()}}},
                {"host", {{"name", "cell-4"}, {"addresses", njson::array({"192.0.2.9"})}}}},
               "2026-11-23T13:10:23.000Z");
  table.upsert("dds-9-realsense.D555_4",
               {{"source", "dds"}, {"in-use", {{"clients", 2}, {"streaming", njson::array({"Depth", "Color"})}}},
                {"host", {{"name", "cell-4"}}}, {"warnings", njson::array({"w1", 2})}},
               "2026-11-23T13:10:24.000Z");
  const njson list = {{"generation", 9}, {"complete", false}, {"devices", table.devices()}};
  for (const std::string& text : {list.dump(), list.dump(2)}) {
    std::string body = text;
    DeviceList out;
    ASSERT_EQ(detail::read_device_list(body, "/v1/devices", out), std::nullopt) << text;
    EXPECT_EQ(out.generation, 9u);
    EXPECT_FALSE(out.complete);
    const auto slices = detail::array_member_elements(text, "devices");
    ASSERT_EQ(out.devices.size(), 6u);
    for (std::size_t i = 0; i < out.devices.size(); ++i) {
      SCOPED_TRACE(i);
      expect_read_as_the_daemon_reads(out.devices[i], list["devices"][i]);
      EXPECT_EQ(out.devices[i].json, slices[i]);
    }
    const auto by_id = [&](const std::string& id) {
      for (const auto& d : out.devices)
        if (d.id == id) return d;
      ADD_FAILURE() << id << " not listed";
      return Device{};
    };
    const auto network = by_id("dds-7-realsense.D455_1");
    EXPECT_EQ(network.name, "Intel RealSense D455 \u2014 caf\u00e9");
    EXPECT_EQ(network.field("multicast-ip"), "\"239.0.0.1\"");
    EXPECT_EQ(by_id(rsd::usb::sighting_id(s)).state, "warning");
  }
}

TEST(DeviceList, RefusesWhatIsNotJson) {
  const std::string bad_utf8[] = {"\xff", "\xc0\xaf", "\xed\xa0\x80", "caf\xc3"};  // stray, overlong, surrogate, cut
  std::vector<std::string> bodies = {
      "", "{", R"({"devices":[]} x)", R"({"devices":[1e400]})", R"({"devices":["\ud800"]})",
      R"({"devices":["\udc00"]})", R"({"devices":[{"\ud83d\ude00\ude00":1}]})", R"({"devices":["\\\udc00"]})",
      "{\"devices\":[\"a\x01\"]}", R"({"devices":[{"id":"a",}]})", R"({"devices":[NaN]})", R"({'devices':[]})",
      R"({"devices":[01]})"};
  for (const auto& b : bad_utf8) bodies.push_back(R"({"devices":[{"id":"x","name":")" + b + R"("}]})");
  for (const auto& text : bodies) {
    SCOPED_TRACE(text);
    EXPECT_TRUE(njson::parse(text, nullptr, false).is_discarded());  // nlohmann's verdict
    std::string body = text;
    DeviceList list;
    const auto problem = detail::read_device_list(body, "/v1/devices", list);
    ASSERT_TRUE(problem);
    EXPECT_EQ(*problem, "GET /v1/devices did not return a JSON object");
  }
  DeviceList out;
  // A NUL, which JSON never has (nlohmann takes it for the end of the text).
  std::string nul("{\"devices\":[]}\0", 15);
  EXPECT_EQ(detail::read_device_list(nul, "/v1/devices", out), "GET /v1/devices did not return a JSON object");
  // An escaped backslash before "udc00" is text, not an escape (the surrogate check
  // looks only where a \u escape is).
  std::string escaped_backslash = R"({"devices":[{"id":"a\\udc00"}]})";
  ASSERT_EQ(detail::read_device_list(escaped_backslash, "/v1/devices", out), std::nullopt);
  ASSERT_EQ(out.devices.size(), 1u);
  EXPECT_EQ(out.devices[0].id, "a\\udc00");
  // JSON, but not the list: said as what is wrong.
  for (const auto& [text, said] : std::vector<std::pair<std::string, std::string>>{
           {"[]", "GET /v1/devices did not return a JSON object"},
           {"null", "GET /v1/devices did not return a JSON object"},
           {R"({"generation":1})", "no \"devices\" array"},
           {R"({"devices":{"id":"x"}})", "no \"devices\" array"},
           {R"({"devices":[{"id":"x"},7]})", "a device is not a JSON object"}}) {
    std::string body = text;
    DeviceList list;
    EXPECT_EQ(detail::read_device_list(body, "/v1/devices", list), said) << text;
  }
  std::string no_id = R"({"devices":[{"name":"x"}]})";
  EXPECT_THROW(detail::read_device_list(no_id, "/v1/devices", out), Error);
  // Numbers are converted by std::from_chars, never by bookworm's RapidJSON, whose
  // exponent arithmetic overflows (CVE-2024-38517): read as nlohmann reads them, the
  // tiny ones as 0 and the huge ones refused.
  std::string tiny = R"({"devices":[{"id":"x","n":[0.00001e-2147483647,1.5e-2147483648,1e-99999,0e-300]}]})";
  ASSERT_EQ(detail::read_device_list(tiny, "/v1/devices", out), std::nullopt);
  EXPECT_EQ(njson::parse(out.devices.at(0).field("n")), njson::parse("[0.0,0.0,0.0,0.0]"));
  for (std::string text : {R"({"devices":[{"id":"x","n":1e2147483647}]})", R"({"devices":[{"id":"x","n":1E+1000}]})",
                           R"({"devices":[{"id":"x","n":-1e309}]})"})
    EXPECT_EQ(detail::read_device_list(text, "/v1/devices", out), "GET /v1/devices did not return a JSON object");
  // Whole numbers keep their kind; beyond 64 bits they are doubles, as in nlohmann.
  std::string whole = R"({"devices":[{"id":"x","domain":-1,"n":[18446744073709551615,-9223372036854775808,)"
                      R"(18446744073709551616,2.5E+100,1e-300,-0.0]}]})";
  ASSERT_EQ(detail::read_device_list(whole, "/v1/devices", out), std::nullopt);
  EXPECT_EQ(out.devices.at(0).domain, -1);
  EXPECT_EQ(njson::parse(out.devices.at(0).field("n")),
            njson::parse("[18446744073709551615,-9223372036854775808,1.8446744073709552e19,2.5e100,1e-300,-0.0]"));
  // The parse is in place: a string with escapes is written back shorter where it
  // stood, and what follows it is still read from where it stands.
  std::string shifted =
      R"({"devices":[{"id":"a\"b\\c\u0041","n":[12,-3.5e2],"domain":7,"name":"\t"}],"generation":5})";
  ASSERT_EQ(detail::read_device_list(shifted, "/v1/devices", out), std::nullopt);
  EXPECT_EQ(out.devices.at(0).id, "a\"b\\cA");
  EXPECT_EQ(out.devices.at(0).domain, 7);
  EXPECT_EQ(out.devices.at(0).name, "\t");
  EXPECT_EQ(out.generation, 5u);
  EXPECT_EQ(njson::parse(out.devices.at(0).field("n")), njson::parse("[12,-350.0]"));
  EXPECT_EQ(out.devices.at(0).json, R"({"id":"a\"b\\c\u0041","n":[12,-3.5e2],"domain":7,"name":"\t"})");
  // In a string such letters and digits are no number: GUIDs are hex (0110e123.4...).
  std::string guid = R"({"devices":[{"id":"x","g":"0110e1234.5","q":"\"1E+5678\\","n":2e10}]})";
  ASSERT_EQ(detail::read_device_list(guid, "/v1/devices", out), std::nullopt);
  EXPECT_EQ(out.devices.at(0).field("g"), "\"0110e1234.5\"");
  // Nesting: as deep as a device-info may be (the daemon cuts them at 16 levels) is
  // read; far deeper is refused, not recursed into (the stack would run out).
  std::string nested = R"({"devices":[{"id":"x","nested":)" + std::string(16, '[') + std::string(16, ']') + "}]}";
  ASSERT_EQ(detail::read_device_list(nested, "/v1/devices", out), std::nullopt);
  EXPECT_EQ(out.devices.at(0).field("nested"), std::string(16, '[') + std::string(16, ']'));
  std::string deep = R"({"devices":[{"id":"x","deep":)" + std::string(200000, '[') + std::string(200000, ']') + "}]}";
  EXPECT_EQ(detail::read_device_list(deep, "/v1/devices", out),
            "GET /v1/devices returned a document nested deeper than 64 levels");
}

// The documents below are the daemon's own (its USB builder and its table), never
// written by hand: the client must read what the daemon writes.
TEST(Device, UsbAndMergedDevicesAsTheDaemonWritesThem) {
  auto s = d435_sighting(0x0210, 480);  // a USB 3 camera on a USB 2 link
  rsd::DeviceTable table;
  table.upsert(rsd::usb::sighting_id(s), rsd::usb::to_json(s, *rsd::usb::find_product(s.vid, s.pid)),
               "2026-11-23T13:10:20.123Z");
  auto d = detail::device_from_text(table.devices().at(0).dump());
  EXPECT_EQ(d.source, "usb");
  ASSERT_TRUE(d.usb);
  EXPECT_EQ(d.usb->bus, 2);
  EXPECT_EQ(d.usb->port_path, "2-1.3");
  ASSERT_EQ(d.warnings.size(), 1u);
  EXPECT_NE(d.warnings[0].find("USB 2"), std::string::npos);
  EXPECT_EQ(d.warning, d.warnings[0]);
  EXPECT_EQ(d.state, "warning");

  // The same camera over DDS: one entry, seen both ways, the warning kept.
  table.upsert("dds-0-realsense.D435_123",
               {{"source", "dds"}, {"serial", "123"}, {"domain", 0}, {"topic-root", "realsense/D435_123"},
                {"name", "Intel RealSense D435"}, {"recovery", false}, {"server", njson::object()}},
               "2026-11-23T13:10:21.000Z");
  auto merged = detail::device_from_text(table.devices().at(0).dump());
  EXPECT_EQ(merged.source, "dds");
  EXPECT_EQ(merged.sources, (std::vector<std::string>{"dds", "usb"}));
  EXPECT_EQ(merged.domain, 0);
  ASSERT_TRUE(merged.usb);
  EXPECT_EQ(merged.state, "warning");
}

TEST(Device, RejectsWhatIsNotADevice) {
  for (const char* bad : {"[]", "{}", R"({"id":5})", R"({"id":""})", "not json"}) {
    try {
      parse_device(bad);
      ADD_FAILURE() << bad;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::malformed_reply) << bad;
    }
  }
}

TEST(Device, SameDeviceIgnoresOnlyTheTimesSeen) {
  const std::string a = R"({"id":"x","name":"n","last-seen":"1","first-seen":"1"})";
  const std::string b = R"({"id":"x","name":"n","last-seen":"2","first-seen":"1"})";
  const std::string c = R"({"id":"x","name":"m","last-seen":"2","first-seen":"1"})";
  // A restarted daemon sets first-seen anew for a camera that never went away.
  const std::string d = R"({"id":"x","name":"n","last-seen":"1","first-seen":"9"})";
  EXPECT_TRUE(detail::same_device(a, b));
  EXPECT_FALSE(detail::same_device(a, c));
  EXPECT_TRUE(detail::same_device(a, d));
}

TEST(Device, CompleteUnlessTheDocumentSaysOtherwise) {
  EXPECT_TRUE(detail::reports_complete(json::parse_or_null(R"({"devices":[]})")));  // an older daemon
  EXPECT_TRUE(detail::reports_complete(json::parse_or_null(R"({"complete":true})")));
  EXPECT_FALSE(detail::reports_complete(json::parse_or_null(R"({"complete":false})")));
  // The daemon's own documents (the shared model writes them), still settling.
  rsd::model::Health health;
  health.complete = false;
  EXPECT_FALSE(detail::health_from_json(client_doc(rsd::model::to_json(health))).complete);
  rsd::model::DomainStatus domain;
  domain.domain = 1;
  domain.state = rsd::model::DomainState::settling;
  EXPECT_FALSE(detail::domain_from_json(client_doc(rsd::model::to_json(domain))).complete);
  domain.complete = true;
  domain.state = rsd::model::DomainState::running;
  const auto running = detail::domain_from_json(client_doc(rsd::model::to_json(domain)));
  EXPECT_TRUE(running.complete);
  EXPECT_EQ(running.state, "running");
  // What is not the daemon's document is named, not half read.
  EXPECT_THROW(detail::domain_from_json(client_doc(njson::parse(R"({"domain":1,"complete":false})"))), Error);
  EXPECT_THROW(detail::health_from_json(client_doc(njson::parse(R"({"status":"ok"})"))), Error);
}

// ---- the status documents, as the daemon writes them (rsd_model's to_json) -------------

// What the client cannot read is a malformed reply, never half a value.
template <class Read>
void expect_malformed(Read read, const njson& doc) {
  try {
    read(client_doc(doc));
    ADD_FAILURE() << doc.dump();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::malformed_reply) << doc.dump();
  }
}

// A double is written in the fewest digits that read back as it, the nearest of them:
// the digits std::to_chars gives (the library writes them with snprintf and reads them
// back with strtod_l, which rs-discover can do without loading libm).
TEST(Json, DoublesAreWrittenInTheFewestDigitsThatReadBack) {
  const auto significant = [](std::string text) {  // "-0.00150" and "1.5e-03": "15"
    text = text.substr(0, text.find_first_of("eE"));
    std::string digits;
    for (const char c : text)
      if (c >= '0' && c <= '9') digits += c;
    digits.erase(0, std::min(digits.find_first_not_of('0'), digits.size()));
    while (!digits.empty() && digits.back() == '0') digits.pop_back();
    return digits;
  };
  std::mt19937_64 random(20261206);
  int checked = 0;
  for (int i = 0; i < 20000; ++i) {
    std::uint64_t bits = random();
    if (i % 3 == 1) bits &= ~((std::uint64_t{1} << 32) - 1);  // short mantissas
    if (i % 3 == 2) bits &= ~((std::uint64_t{1} << 52) - 1);  // powers of two
    double d;
    std::memcpy(&d, &bits, sizeof d);
    if (!std::isfinite(d) || d == 0) continue;
    const std::string text = rsdiscovery::json::dump(rsdiscovery::json::Value(d));
    SCOPED_TRACE(text);
    EXPECT_EQ(std::strtod(text.c_str(), nullptr), d);
    char shortest[64];
    const auto end = std::to_chars(shortest, shortest + sizeof shortest, d, std::chars_format::scientific).ptr;
    EXPECT_EQ(significant(text), significant(std::string(shortest, end)));
    ++checked;
  }
  EXPECT_GT(checked, 19000);
}

TEST(Documents, DomainEntryAsTheDaemonWritesIt) {
  rsd::model::DomainStatus s;
  s.domain = 7;
  s.state = rsd::model::DomainState::rebuilding;
  s.participant_guid = "01107948.66908ead.429992d1.000001c1";
  s.devices = 3;
  s.accepted = 12;
  s.rejected = {{"malformed", 2}};
  s.interfaces = {{"eth0", {"192.0.2.2"}}};
  s.complete = true;
  const auto doc = rsd::model::to_json(s);
  const auto read = detail::domain_from_json(client_doc(doc));
  EXPECT_EQ(read.domain, 7);
  EXPECT_EQ(read.state, "rebuilding");
  EXPECT_EQ(read.participant_guid, s.participant_guid);
  EXPECT_EQ(read.devices, 3u);
  EXPECT_EQ(read.accepted, 12u);
  EXPECT_EQ(read.rejected, (std::map<std::string, std::uint64_t>{{"malformed", 2}}));
  EXPECT_TRUE(read.complete);
  EXPECT_EQ(njson::parse(read.json), doc);
  for (const char* bad : {R"([])", R"({"domain": 1})", R"({"domain": 300, "state": "running"})",
                          R"({"domain": 1, "state": "joining"})"})
    expect_malformed(detail::domain_from_json, njson::parse(bad));
  auto bad = doc;
  bad["rejected"]["malformed"] = -2;
  expect_malformed(detail::domain_from_json, bad);
}

TEST(Documents, HealthAsTheDaemonWritesIt) {
  rsd::model::Health h;
  h.version = "0.1.0";
  h.devices = 2;
  h.complete = true;
  h.http = rsd::model::HttpHealth{"127.0.0.1:8036", "127.0.0.1:8035", "systemd", false};
  const auto doc = rsd::model::to_json(h);
  const auto read = detail::health_from_json(client_doc(doc));
  EXPECT_EQ(read.status, "ok");
  EXPECT_EQ(read.version, "0.1.0");
  EXPECT_EQ(read.devices, 2u);
  EXPECT_TRUE(read.complete);
  EXPECT_EQ(njson::parse(read.json), doc);
  expect_malformed(detail::health_from_json, njson::parse(R"({"status": "ok", "version": 1})"));
}

TEST(Documents, ParticipantAsTheDaemonWritesIt) {
  rsd::model::Participant p;
  p.domain = 3;
  p.guid = "010f78fd.3e2482db.00000000.000001c1";
  p.name = "camera";
  p.vendor_id = rsd::model::vendor_id_of(p.guid);
  p.vendor = rsd::model::vendor_of(p.vendor_id);
  p.addresses = {"192.0.2.2"};
  p.first_seen = "2026-11-24T06:50:45.206Z";
  p.last_seen = "2026-11-24T06:50:46.000Z";
  p.device_info_writers = 2;
  p.devices = 1;
  p.topic_roots = {"realsense/D555_1"};
  p.endpoints = 40;
  auto read = detail::participant_from_json(client_doc(rsd::model::to_json(p)));
  EXPECT_EQ(read.domain, 3);
  EXPECT_EQ(read.guid, p.guid);
  EXPECT_EQ(read.name, "camera");
  EXPECT_EQ(read.vendor, "fast-dds");
  EXPECT_EQ(read.addresses, p.addresses);
  EXPECT_EQ(read.host, "");  // not said: a realdds (Fast DDS) peer
  EXPECT_FALSE(read.lease_seconds);
  EXPECT_EQ(read.state, "alive");
  EXPECT_EQ(read.first_seen, p.first_seen);
  EXPECT_EQ(read.last_seen, p.last_seen);
  EXPECT_EQ(read.device_info_writers, 2u);
  EXPECT_EQ(read.devices, 1u);
  EXPECT_FALSE(read.never_announced);
  EXPECT_EQ(read.topic_roots, p.topic_roots);
  EXPECT_EQ(read.endpoints, 40u);
  p.host = "vm";
  p.process = "python";
  p.pid = 12;
  p.lease_seconds = 10.0;
  p.state = rsd::model::ParticipantState::gone;
  read = detail::participant_from_json(client_doc(rsd::model::to_json(p)));
  EXPECT_EQ(read.host, "vm");
  EXPECT_EQ(read.process, "python");
  EXPECT_EQ(read.lease_seconds, 10.0);
  EXPECT_EQ(read.state, "gone");
  // A vendor a newer daemon knows and this client does not reads as "other".
  auto doc = rsd::model::to_json(p);
  doc["vendor"] = "a-newer-one";
  EXPECT_EQ(detail::participant_from_json(client_doc(doc)).vendor, "other");
  for (const char* key : {"guid", "state", "addresses", "never-announced"}) {
    auto bad = rsd::model::to_json(p);
    bad[key] = 5;
    expect_malformed(detail::participant_from_json, bad);
  }
  auto bad = rsd::model::to_json(p);
  bad["state"] = "sleeping";
  expect_malformed(detail::participant_from_json, bad);
}

TEST(Documents, CameraClientsAsTheDaemonWritesThem) {
  rsd::model::DeviceClients c;
  c.clients.push_back({"g", "app", rsd::model::Vendor::cyclone_dds, "01.10", {"192.0.2.1"}, "pc", "python", 42, "T",
                       {"Depth"}, {"/robot/viewer"}});
  c.streams = {{"Depth", 1}};
  const auto doc = rsd::model::to_json(c);
  const auto read = detail::clients_from_json(client_doc(doc));
  ASSERT_EQ(read.clients.size(), 1u);
  EXPECT_EQ(read.clients[0].guid, "g");
  EXPECT_EQ(read.clients[0].name, "app");
  EXPECT_EQ(read.clients[0].vendor, "cyclone-dds");
  EXPECT_EQ(read.clients[0].host, "pc");
  EXPECT_EQ(read.clients[0].process, "python");
  EXPECT_EQ(read.clients[0].since, "T");
  EXPECT_EQ(read.clients[0].streams, std::vector<std::string>{"Depth"});
  EXPECT_EQ(read.clients[0].ros_nodes, std::vector<std::string>{"/robot/viewer"});
  EXPECT_EQ(read.streams, (std::map<std::string, std::uint64_t>{{"Depth", 1}}));
  // A daemon from before ROS 2 node names: read as none.
  auto older = doc;
  older["clients"][0].erase("ros-nodes");
  EXPECT_TRUE(detail::clients_from_json(client_doc(older)).clients[0].ros_nodes.empty());
  expect_malformed(detail::clients_from_json, njson::parse(R"({"clients":[{}],"streams":{}})"));
  expect_malformed(detail::clients_from_json, njson::parse(R"({"clients":[],"streams":{"Depth":-1}})"));
}

TEST(Documents, ExpectedCamerasAsTheDaemonWritesThem) {
  rsd::model::ExpectedReport report;
  report.complete = true;
  report.present.push_back({{"front", "1", ""}, "dds-0-a", std::nullopt, std::nullopt});
  report.missing.push_back({{"wrist", "", "realsense/D555_2"}, std::nullopt, "2026-11-24T06:50:46.000Z", "stopping"});
  const auto read = detail::expected_from_json(client_doc(rsd::model::to_json(report)));
  EXPECT_TRUE(read.complete);
  ASSERT_EQ(read.present.size(), 1u);
  EXPECT_EQ(read.present[0].name, "front");
  EXPECT_EQ(read.present[0].key(), "1");
  EXPECT_EQ(read.present[0].id, "dds-0-a");
  ASSERT_EQ(read.missing.size(), 1u);
  EXPECT_EQ(read.missing[0].key(), "realsense/D555_2");
  EXPECT_EQ(read.missing[0].last_seen, "2026-11-24T06:50:46.000Z");
  EXPECT_EQ(read.missing[0].reason, "stopping");
  expect_malformed(detail::expected_from_json, njson::parse(R"({"complete":true,"present":[{"name":"x"}],"missing":[]})"));
}

TEST(Filter, BuildsTheQueryWithEncoding) {
  DeviceFilter f;
  EXPECT_EQ(detail::devices_path(f), "/v1/devices");
  f.domain(7).product_line("D4 00&x").source("usb");
  EXPECT_EQ(detail::devices_path(f), "/v1/devices?domain=7&product-line=D4%2000%26x&source=usb");
  DeviceFilter more;
  more.domain(1).domain(2).serial("ab12").name("D455 ").address("192.0.2.2");
  EXPECT_EQ(detail::devices_path(more), "/v1/devices?domain=1&domain=2&serial=ab12&name=D455%20&address=192.0.2.2");
  EXPECT_EQ(detail::devices_path(DeviceFilter().in_use(true)), "/v1/devices?in-use=true");
  EXPECT_EQ(detail::devices_path(DeviceFilter().in_use(false)), "/v1/devices?in-use=false");
}

// Opaque values behave as values: a copy is its own, a moved-from one reads as new
// and takes settings again, and the defaults are the documented ones.
TEST(Options, CopiesAreIndependentAndMovedFromReadsAsNew) {
  DeviceFilter a;
  a.serial("x").domain(3);
  DeviceFilter b = a;
  b.serial("y");
  EXPECT_EQ(a.serial(), "x");
  EXPECT_EQ(b.serial(), "y");
  EXPECT_EQ(b.domains(), std::vector<int>{3});
  DeviceFilter c = std::move(a);
  EXPECT_EQ(c.serial(), "x");
  EXPECT_EQ(a.serial(), "");  // NOLINT(bugprone-use-after-move): reads as new, on purpose
  a.name("again");
  EXPECT_EQ(a.name(), "again");
  b = c;
  EXPECT_EQ(b.serial(), "x");
  EXPECT_FALSE(DeviceFilter().in_use());

  WatchOptions w;
  EXPECT_FALSE(w.initial());
  EXPECT_TRUE(w.reconnect());
  EXPECT_EQ(w.max_reconnect_delay(), std::chrono::milliseconds(2000));
  EXPECT_EQ(w.idle_timeout(), std::chrono::milliseconds(60000));
  EXPECT_EQ(w.complete_timeout(), std::chrono::milliseconds(10000));
  EXPECT_FALSE(w.last_event_id());
  w.filter(c).last_event_id(42);
  WatchOptions w2 = w;
  EXPECT_EQ(w2.filter().serial(), "x");
  EXPECT_EQ(w2.last_event_id(), 42u);

  ClientOptions o;
  EXPECT_EQ(o.connect_timeout(), std::chrono::milliseconds(2000));
  EXPECT_EQ(o.request_timeout(), std::chrono::milliseconds(10000));
  EXPECT_EQ(o.complete_timeout(), std::chrono::milliseconds(5000));
  EXPECT_FALSE(o.on_busy());
}

TEST(Filter, HostSelectsAnotherHostsCameras) {
  DeviceFilter f;
  f.host("rig pc");
  EXPECT_EQ(detail::devices_path(f), "/v1/devices?host=rig%20pc");
}

TEST(Device, SharingHostOfARemoteUsbCameraOnly) {
  const auto remote = parse_device(R"({"id":"usb-1.rig","source":"remote-usb","sources":["remote-usb"],"name":"x",
    "host":{"name":"rig","addresses":["192.0.2.1","198.51.100.1"],"participant-guid":"01.02"}})");
  const auto host = sharing_host(remote);
  ASSERT_TRUE(host);
  EXPECT_EQ(host->name, "rig");
  EXPECT_EQ(host->addresses, (std::vector<std::string>{"192.0.2.1", "198.51.100.1"}));
  EXPECT_EQ(host->participant_guid, "01.02");
  EXPECT_FALSE(sharing_host(parse_device(R"({"id":"usb-1","source":"usb","name":"x"})")));
  // A remote-usb camera whose host is not readable still is one: a value, no name.
  const auto unnamed = sharing_host(parse_device(R"({"id":"usb-2.x","source":"remote-usb","name":"x"})"));
  ASSERT_TRUE(unnamed);
  EXPECT_EQ(unnamed->name, "");
}

TEST(Device, InUseOfACameraWithClientsOnly) {
  const auto used = parse_device(R"({"id":"dds-0-realsense.D555_1","source":"dds","name":"x",
    "in-use":{"clients":2,"streaming":["Depth","Color"]}})");
  const auto in_use = in_use_of(used);
  ASSERT_TRUE(in_use);
  EXPECT_EQ(in_use->clients, 2u);
  EXPECT_EQ(in_use->streaming, (std::vector<std::string>{"Depth", "Color"}));
  EXPECT_FALSE(in_use_of(parse_device(R"({"id":"dds-0-realsense.D555_2","source":"dds","name":"x"})")));
  EXPECT_FALSE(in_use_of(parse_device(R"({"id":"usb-1","source":"usb","name":"x"})")));
}

ErrorCode code_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.code();
  }
  return ErrorCode::cancelled;  // "no error" marker for these tests
}

// ---- answers the real daemon never gives: a raw stand-in ----------------------------------------
//
// The daemon's ApiServer cannot be made to misbehave (its replies come from the shared
// model and the table), so what a client must survive from something else on the
// socket (a server of another API version, a broken proxy, a hostile peer) is played
// by a raw stand-in.

// A stand-in for an endpoint that is not the daemon: on each connection it reads one
// request head and hands the socket to `answer` (with the request's path), which
// writes what it likes; connections stay open until the server goes.
class RawServer {
 public:
  using Answer = std::function<void(int fd, const std::string& path)>;
  explicit RawServer(Answer answer) : answer_(std::move(answer)) {
    path_ = (std::filesystem::temp_directory_path() / ("rsd-client-raw-" + std::to_string(getpid()) + "-" +
                                                        std::to_string(counter_++) + ".sock"))
                .string();
    listener_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::snprintf(a.sun_path, sizeof a.sun_path, "%s", path_.c_str());
    ::unlink(path_.c_str());
    if (::bind(listener_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(listener_, 8) != 0)
      throw std::runtime_error("cannot listen on " + path_);
    thread_ = std::thread([this] { serve(); });
  }
  ~RawServer() {
    ::shutdown(listener_, SHUT_RDWR);  // ends the accept
    thread_.join();
    for (int fd : open_) ::close(fd);
    ::close(listener_);
    ::unlink(path_.c_str());
  }
  std::string endpoint() const { return "unix:" + path_; }

  // Writes `chunk` again and again until the client stops reading and goes.
  static void flood(int fd, const std::string& chunk) {
    while (::send(fd, chunk.data(), chunk.size(), MSG_NOSIGNAL) > 0) {
    }
  }

 private:
  void serve() {
    for (;;) {
      const int fd = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd < 0) return;
      open_.push_back(fd);
      std::string head;
      char buf[4096];
      while (head.find("\r\n\r\n") == std::string::npos) {
        const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
        if (n <= 0) break;
        head.append(buf, static_cast<std::size_t>(n));
      }
      const auto sp = head.find(' ');
      answer_(fd, sp == std::string::npos ? "" : head.substr(sp + 1, head.find(' ', sp + 1) - sp - 1));
    }
  }
  static inline std::atomic<int> counter_{0};
  Answer answer_;
  std::string path_;
  int listener_ = -1;
  std::vector<int> open_;
  std::thread thread_;
};

void say(int fd, const std::string& text) { ::send(fd, text.data(), text.size(), MSG_NOSIGNAL); }

// A whole JSON answer; the connection is closed after it, so the client's next request
// comes on a connection of its own (RawServer reads one request per connection).
void reply(int fd, int status, const std::string& body) {
  say(fd, "HTTP/1.1 " + std::to_string(status) + " Answer\r\nContent-Type: application/json\r\nContent-Length: " +
              std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body);
}

TEST(Client, MalformedRepliesAreNamed) {
  std::mutex m;
  std::string body;
  RawServer server([&](int fd, const std::string&) {
    std::lock_guard lock(m);
    reply(fd, 200, body);
  });
  Client c(server.endpoint());
  for (const char* bad : {"not json", "[]", R"({"devices":5})", R"({"devices":[{"name":"no id"}]})"}) {
    {
      std::lock_guard lock(m);
      body = bad;
    }
    try {
      c.list_devices();
      ADD_FAILURE() << bad;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::malformed_reply) << bad;
      EXPECT_NE(std::string(e.what()).find("malformed reply"), std::string::npos) << e.what();
    }
  }
}

TEST(Client, AnotherApiVersionIsAVersionMismatch) {
  std::atomic<int> status{404};
  RawServer server([&](int fd, const std::string& path) {
    if (path == "/healthz") {
      rsd::model::Health health;
      health.version = "9.9.9";
      health.complete = true;
      return reply(fd, 200, rsd::model::to_json(health).dump());
    }
    reply(fd, status, status == 404 ? R"({"error":"unknown path","status":404})" : R"({"error":"boom","status":500})");
  });
  Client c(server.endpoint());
  try {
    c.list_devices();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::version_mismatch);
    std::string what = e.what();
    EXPECT_NE(what.find("version mismatch"), std::string::npos) << what;
    EXPECT_NE(what.find("9.9.9"), std::string::npos) << what;  // the daemon's version, from /healthz
  }
  status = 500;
  EXPECT_EQ(code_of([&] { c.list_devices(); }), ErrorCode::http_error);
}

TEST(Client, AnotherServerIsNotCalledAnotherVersion) {
  // Not rs-discoveryd at all: 404 everywhere, /healthz too.
  RawServer server([&](int fd, const std::string&) { reply(fd, 404, "<html>Not Found</html>"); });
  try {
    Client(server.endpoint()).list_devices();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::version_mismatch);
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("something other than rs-discoveryd answers at " + server.endpoint(), 0), 0u) << what;
    EXPECT_EQ(what.find("version mismatch"), std::string::npos) << what;
  }
}

TEST(Client, ADaemonOlderThanCompletenessIsNotWaitedFor) {
  // Its list has no "complete": there is nothing to wait for, so one request answers.
  std::atomic<int> lists{0};
  RawServer server([&](int fd, const std::string&) {
    ++lists;
    reply(fd, 200, R"({"generation":7,"devices":[]})");
  });
  const auto l = Client(server.endpoint()).list();
  EXPECT_TRUE(l.complete);
  EXPECT_EQ(l.generation, 7u);
  EXPECT_EQ(lists, 1);
}

TEST(Client, AnswersBeyondTheBoundAreRefusedNotRead) {
  const std::string mib(std::size_t{1} << 20, ' ');
  const std::map<std::string, RawServer::Answer> endpoints = {
      {"a length beyond the bound", [](int fd, const std::string&) {
         say(fd, "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: 1000000000000\r\n\r\n{");
       }},
      {"chunks without end", [&](int fd, const std::string&) {
         say(fd, "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n");
         RawServer::flood(fd, "100000\r\n" + mib + "\r\n");
       }},
      {"one chunk without end", [&](int fd, const std::string&) {
         say(fd, "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n"
                 "fffffffffff\r\n");
         RawServer::flood(fd, mib);
       }},
      {"a body until a close that never comes", [&](int fd, const std::string&) {
         say(fd, "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\n\r\n");
         RawServer::flood(fd, mib);
       }},
  };
  for (const auto& [what, answer] : endpoints) {
    RawServer server(answer);
    Client c(server.endpoint());
    try {
      c.list_devices();
      ADD_FAILURE() << what << ": listed";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::malformed_reply) << what;
      EXPECT_NE(std::string(e.what()).find("the answer to GET /v1/devices is larger than 64 MiB (not read)"),
                std::string::npos)
          << what << ": " << e.what();
    }
  }
}

// Until the client has read all that was sent on `fd`, so the next send is a read
// of its own on the client's side.
void wait_drained(int fd) {
  const auto give_up = std::chrono::steady_clock::now() + 10s;
  for (int queued = 1; queued > 0 && std::chrono::steady_clock::now() < give_up;) {
    if (::ioctl(fd, SIOCOUTQ, &queued) != 0) return;
    if (queued > 0) std::this_thread::yield();
  }
}

TEST(Client, AReplyInPiecesIsReadWholeInEachFraming) {
  // The reader reads straight into its buffer, from a page to 64 KiB at a time: pieces
  // across those sizes, each read on its own, in each way a reply can be framed.
  std::string body = R"({"complete":true,"generation":5,"devices":[)";
  const int count = 300;
  for (int i = 0; i < count; ++i)
    body += (i ? "," : "") + std::string(R"({"id":"dev-)") + std::to_string(i) + R"(","name":"camera )" +
            std::to_string(i) + " " + std::string(200, 'x') + R"("})";
  body += "]}";
  ASSERT_GT(body.size(), std::size_t{70000});
  const std::vector<std::size_t> sizes = {1, 4095, 4097, 65536, 70000, 3};
  const auto in_pieces = [&](int fd, const std::string& text, bool chunked) {
    for (std::size_t at = 0, k = 0; at < text.size(); ++k) {
      const std::string piece = text.substr(at, sizes[k % sizes.size()]);
      at += piece.size();
      char size[32];
      std::snprintf(size, sizeof size, "%zx\r\n", piece.size());
      say(fd, chunked ? size + piece + "\r\n" : piece);
      wait_drained(fd);
    }
  };
  const std::string head = "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\n";
  const std::map<std::string, RawServer::Answer> framings = {
      {"a length", [&](int fd, const std::string&) {
         in_pieces(fd, head + "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body, false);
       }},
      {"chunks", [&](int fd, const std::string&) {
         say(fd, head + "Transfer-Encoding: chunked\r\n\r\n");
         in_pieces(fd, body, true);
         say(fd, "0\r\n\r\n");
       }},
      {"until the close", [&](int fd, const std::string&) {
         in_pieces(fd, head + "Connection: close\r\n\r\n" + body, false);
         ::shutdown(fd, SHUT_WR);
       }},
  };
  for (const auto& [framing, answer] : framings) {
    RawServer server(answer);
    const auto list = Client(server.endpoint()).list();
    ASSERT_EQ(list.devices.size(), std::size_t{count}) << framing;
    EXPECT_EQ(list.generation, 5u) << framing;
    for (int i = 0; i < count; ++i) {
      EXPECT_EQ(list.devices[i].id, "dev-" + std::to_string(i)) << framing;
      EXPECT_EQ(list.devices[i].name, "camera " + std::to_string(i) + " " + std::string(200, 'x')) << framing;
    }
  }
}

TEST(Watch, AnEndlessEventEndsTheWatchWithAnError) {
  const std::string mib(std::size_t{1} << 20, 'x');
  RawServer server([&](int fd, const std::string& path) {
    if (path.rfind("/v1/devices", 0) == 0) {
      const std::string list = R"({"generation":3,"devices":[],"complete":true})";
      say(fd, "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: " +
                  std::to_string(list.size()) + "\r\n\r\n" + list);
      return;
    }
    say(fd, "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\n\r\nevent: added\nid: 4\ndata: ");
    RawServer::flood(fd, mib);  // one data line, never ended
  });
  Client c(server.endpoint());
  Watch w = c.watch();
  try {
    w.next(30s);
    ADD_FAILURE() << "the watch went on";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::malformed_reply);
    EXPECT_NE(std::string(e.what()).find("an event larger than 16 MiB"), std::string::npos) << e.what();
  }
}

TEST(Watch, MalformedEventsEndTheWatchWithAnError) {
  RawServer server([](int fd, const std::string& path) {
    if (path.rfind("/v1/devices", 0) == 0) return reply(fd, 200, R"({"generation":10,"complete":true,"devices":[]})");
    say(fd, "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\n\r\nevent: added\nid: 11\ndata: {not json\n\n");
  });
  Client c(server.endpoint());
  Watch w = c.watch();
  EXPECT_EQ(code_of([&] { w.next(5s); }), ErrorCode::malformed_reply);
}

// ---- no daemon at all --------------------------------------------------------------------------

TEST(Client, NotRunningNamesTheSocketTried) {
  auto dir = std::filesystem::temp_directory_path() / ("rsd-client-nr-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  std::string path = (dir / "none.sock").string();
  try {
    Client(Endpoint::parse(path)).list_devices();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::not_running);
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  // A stale socket file: bound once, nobody listening.
  std::string stale = (dir / "stale.sock").string();
  int fd = socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", stale.c_str());
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  close(fd);
  try {
    Client(Endpoint::parse(stale)).health();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::not_running);
    EXPECT_NE(std::string(e.what()).find("nothing listens"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(Watch, FailsAtOnceWhenTheDaemonIsAbsent) {
  Client c(Endpoint::parse("unix:/nonexistent-dir/rsd.sock"));
  EXPECT_EQ(code_of([&] { c.watch(); }), ErrorCode::not_running);
}

// ---- the real ApiServer ------------------------------------------------------------------------

// tests/api/api_harness as a child process: the daemon's own ApiServer over a
// table this test writes through the harness's stdin, on a Unix socket of its own. What
// the daemon does on its own terms is reached through it: an incomplete table (its
// domains' first discovery), dropped streams (api-stop, api-start: the table and its
// change log live on, as across a lost connection), a gap in the change log (a small
// --log-capacity) and a daemon restart (another harness on the same socket, at
// generations of its own). Its debug log names every request it answers: tests wait
// on those lines, not on the clock.
class Harness {
 public:
  explicit Harness(const std::vector<std::string>& flags = {}) {
    dir_ = std::filesystem::temp_directory_path() /
           ("rsd-client-unit-" + std::to_string(getpid()) + "-" + std::to_string(counter_++));
    std::filesystem::create_directories(dir_);
    socket_ = (dir_ / "api.sock").string();
    spawn(flags);
  }
  ~Harness() {
    finish();
    std::filesystem::remove_all(dir_);
  }
  Harness(const Harness&) = delete;
  Harness& operator=(const Harness&) = delete;

  std::string endpoint() const { return "unix:" + socket_; }

  // One stdin command; the table's generation after it (the harness's "ok N").
  std::uint64_t command(const std::string& line) {
    std::lock_guard lock(command_mutex_);
    const std::string text = line + "\n";
    if (::send(in_, text.data(), text.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(text.size()))
      throw std::runtime_error("api_harness: cannot send '" + line + "'");
    const std::string answer = read_line(10s);
    if (answer.rfind("ok ", 0) != 0)
      throw std::runtime_error("api_harness: '" + line + "' answered '" + answer + "'");
    return std::stoull(answer.substr(3));
  }
  std::uint64_t upsert(const std::string& id, const njson& doc) { return command("upsert " + id + " " + doc.dump()); }
  std::uint64_t remove(const std::string& id) { return command("remove " + id); }

  // This harness stops and another starts on the same socket: a daemon restart.
  void restart(const std::vector<std::string>& flags) {
    finish();
    spawn(flags);
  }

  // Waits until the running harness has answered `n` requests whose log line holds
  // `what` (e.g. "GET /v1/devices -> ", any status).
  bool wait_requests(const std::string& what, std::size_t n, std::chrono::milliseconds timeout = 10s) {
    std::unique_lock lock(err_mutex_);
    return err_cv_.wait_for(lock, timeout, [&] { return count_locked(what) >= n; });
  }

 private:
  void spawn(const std::vector<std::string>& flags) {
    int in[2], out[2], err[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, in) != 0 || ::pipe2(out, O_CLOEXEC) != 0 ||
        ::pipe2(err, O_CLOEXEC) != 0)
      throw std::runtime_error(std::string("api_harness: ") + std::strerror(errno));
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, in[1], 0);
    posix_spawn_file_actions_adddup2(&actions, out[1], 1);
    posix_spawn_file_actions_adddup2(&actions, err[1], 2);
    std::vector<std::string> args = {RSD_API_HARNESS, "--socket", socket_};
    args.insert(args.end(), flags.begin(), flags.end());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int rc = ::posix_spawn(&pid_, RSD_API_HARNESS, &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(in[1]);
    ::close(out[1]);
    ::close(err[1]);
    in_ = in[0];
    out_ = out[0];
    out_buffer_.clear();
    {
      std::lock_guard lock(err_mutex_);
      err_lines_.clear();
    }
    err_thread_ = std::thread([this, fd = err[0]] { read_errors(fd); });
    if (rc != 0) {
      pid_ = -1;
      finish();
      throw std::runtime_error(std::string("cannot start " RSD_API_HARNESS ": ") + std::strerror(rc));
    }
    const std::string ready = read_line(10s);
    if (ready.rfind("ready ", 0) != 0) {
      finish();
      throw std::runtime_error("api_harness did not start: '" + ready + "'");
    }
  }

  // Stops the harness ("stop": the ApiServer stops as the daemon's does) and reaps it;
  // a harness that does not stop, or exits non-zero (a sanitizer's finding), fails the test.
  void finish() {
    std::string said = "not started";
    int status = 0;
    if (pid_ > 0) {
      ::send(in_, "stop\n", 5, MSG_NOSIGNAL);
      said = read_line(10s);
      if (said.rfind("stopped ", 0) != 0) ::kill(pid_, SIGKILL);
      while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
      }
    }
    if (in_ >= 0) ::close(in_);
    if (out_ >= 0) ::close(out_);
    in_ = out_ = -1;
    if (err_thread_.joinable()) err_thread_.join();  // the harness's end closed its stderr
    if (pid_ > 0) {
      if (said.rfind("stopped ", 0) != 0)
        ADD_FAILURE() << "api_harness did not stop: '" << said << "'";
      else if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
        ADD_FAILURE() << "api_harness ended with status " << status;
    }
    if (::testing::Test::HasFailure()) {
      std::lock_guard lock(err_mutex_);
      std::cerr << "api_harness's log, last lines:\n";
      for (std::size_t i = err_lines_.size() > 40 ? err_lines_.size() - 40 : 0; i < err_lines_.size(); ++i)
        std::cerr << "  " << err_lines_[i] << "\n";
    }
    pid_ = -1;
  }

  // One line of the harness's stdout, or "<timeout>"/"<eof>".
  std::string read_line(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      if (const auto nl = out_buffer_.find('\n'); nl != std::string::npos) {
        std::string line = out_buffer_.substr(0, nl);
        out_buffer_.erase(0, nl + 1);
        return line;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left <= 0ms) return "<timeout>";
      pollfd p{out_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;  // EINTR, or the deadline: look again
      char buf[4096];
      const ssize_t n = ::read(out_, buf, sizeof buf);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return "<eof>";
      out_buffer_.append(buf, static_cast<std::size_t>(n));
    }
  }

  void read_errors(int fd) {
    std::string partial;
    char buf[4096];
    for (;;) {
      const ssize_t n = ::read(fd, buf, sizeof buf);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      partial.append(buf, static_cast<std::size_t>(n));
      std::lock_guard lock(err_mutex_);
      for (auto nl = partial.find('\n'); nl != std::string::npos; nl = partial.find('\n')) {
        err_lines_.push_back(partial.substr(0, nl));
        partial.erase(0, nl + 1);
      }
      err_cv_.notify_all();
    }
    ::close(fd);
  }

  std::size_t count_locked(const std::string& what) const {
    std::size_t n = 0;
    for (const auto& line : err_lines_)
      if (line.find(what) != std::string::npos) ++n;
    return n;
  }

  static inline std::atomic<int> counter_{0};
  std::filesystem::path dir_;
  std::string socket_;
  pid_t pid_ = -1;
  int in_ = -1;   // its stdin (a socket: a send to a harness that died fails, never SIGPIPEs)
  int out_ = -1;  // its stdout: "ready", "ok N", "stopped"
  std::string out_buffer_;
  std::mutex command_mutex_;
  std::thread err_thread_;
  std::mutex err_mutex_;
  std::condition_variable err_cv_;
  std::vector<std::string> err_lines_;  // its stderr: the ApiServer's log
};

// A camera as a source gives it to the table (which adds id, first-seen, last-seen).
njson camera(const njson& extra = njson::object()) {
  njson doc = {{"source", "dds"}, {"domain", 7}, {"name", "Intel RealSense D455"}};
  doc.update(extra);
  return doc;
}

// Domain 7's first discovery still running (the list says "complete": false), or over.
const std::string kIncomplete = R"([{"domain":7,"complete":false}])";
const std::string kComplete = R"([{"domain":7,"complete":true}])";
const std::string kList = "GET /v1/devices -> ";  // the harness's log line of an unfiltered list

std::optional<Event> next_event(Watch& w) { return w.next(10s); }

TEST(Client, ListsAndGets) {
  Harness h;
  h.upsert("a", camera({{"serial", "111"}}));
  h.upsert("b", camera({{"serial", "222"}, {"name", "Intel RealSense D405"}}));
  Client c(h.endpoint());
  auto list = c.list_devices();
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].id, "a");
  EXPECT_EQ(list[1].id, "b");
  EXPECT_EQ(list[1].name, "Intel RealSense D405");
  EXPECT_EQ(c.get_device("a").serial, "111");
  EXPECT_EQ(c.get_device("222").id, "b");  // a serial names a device too
  EXPECT_FALSE(c.find_device("unknown"));
  EXPECT_EQ(code_of([&] { c.get_device("unknown"); }), ErrorCode::not_found);
  const auto health = c.health();
  EXPECT_EQ(health.version, "0.0.0-harness");
  EXPECT_EQ(health.devices, 2u);
}

TEST(Client, TellsAGoneCameraFromOneNeverSeen) {
  Harness h;
  h.upsert("a", camera({{"serial", "111"}}));
  h.command("remove a lease-expired");
  Client c(h.endpoint());
  EXPECT_FALSE(c.find_device("a"));
  EXPECT_FALSE(c.find_device("never-seen"));
  const auto status_of = [&](const std::string& id) {
    try {
      c.get_device(id);
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::not_found) << id;
      return std::pair(e.http_status(), std::string(e.what()));
    }
    return std::pair(200, std::string());
  };
  const auto [gone_status, gone_words] = status_of("a");
  EXPECT_EQ(gone_status, 410);
  EXPECT_NE(gone_words.find("lease-expired"), std::string::npos) << gone_words;  // says why
  EXPECT_EQ(status_of("111").first, 410);  // by its serial too
  EXPECT_EQ(status_of("never-seen").first, 404);
  const njson history = njson::parse(c.device_history("a"));
  EXPECT_EQ(history["state"], "gone");
  EXPECT_EQ(history["gone"]["reason"], "lease-expired");
  EXPECT_EQ(history["removals"]["lease-expired"], 1);
  try {
    c.device_history("never-seen");
    ADD_FAILURE() << "a history for a camera never seen";
  } catch (const Error& e) {
    EXPECT_EQ(e.http_status(), 404);
  }
}

TEST(Client, ListWaitsForTheCompleteTable) {
  Harness h({"--domains", kIncomplete});
  Client c(h.endpoint());
  auto pending = std::async(std::launch::async, [&] { return c.list(); });
  ASSERT_TRUE(h.wait_requests(kList, 2));  // asked again while incomplete
  EXPECT_EQ(pending.wait_for(0s), std::future_status::timeout);  // and still waits
  const auto generation = h.upsert("a", camera());
  h.command("domains " + kComplete);
  auto l = pending.get();
  EXPECT_TRUE(l.complete);
  EXPECT_EQ(l.generation, generation);
  ASSERT_EQ(l.devices.size(), 1u);
  EXPECT_EQ(l.devices[0].id, "a");

  // Told not to wait: the partial answer, said to be partial.
  h.command("domains " + kIncomplete);
  ClientOptions now;
  now.complete_timeout(0ms);
  l = Client(h.endpoint(), now).list();
  EXPECT_FALSE(l.complete);
  EXPECT_EQ(l.generation, generation);
  EXPECT_EQ(l.devices.size(), 1u);

  // The wait is bounded: a table that never completes is answered from after the bound.
  ClientOptions brief;
  brief.complete_timeout(200ms);
  const auto t0 = std::chrono::steady_clock::now();
  l = Client(h.endpoint(), brief).list();
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_FALSE(l.complete);
  EXPECT_GE(took, 200ms);
  EXPECT_LT(took, 2s);
}

TEST(Client, FindWaitsForACameraWhileTheTableIsIncomplete) {
  Harness h({"--domains", kIncomplete});
  Client c(h.endpoint());
  auto pending = std::async(std::launch::async, [&] { return c.find_device("later"); });
  ASSERT_TRUE(h.wait_requests("GET /v1/devices/later -> 404", 2));  // not yet heard: asked again
  EXPECT_EQ(pending.wait_for(0s), std::future_status::timeout);
  h.upsert("later", camera({{"name", "L"}}));
  auto d = pending.get();
  ASSERT_TRUE(d);
  EXPECT_EQ(d->name, "L");
  ClientOptions now;
  now.complete_timeout(0ms);
  EXPECT_FALSE(Client(h.endpoint(), now).find_device("never"));
  // A 404 from a complete table is final at once.
  h.command("domains " + kComplete);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(code_of([&] { c.get_device("unknown"); }), ErrorCode::not_found);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);
}

TEST(Watch, StreamsFromTheListsGenerationWithNothingLostOrTwice) {
  Harness h;
  h.upsert("a", camera());
  Client c(h.endpoint());
  // A writer changes the table while the watch lists it and opens its stream: what
  // comes between the two must be told once, and nothing from before the list again.
  std::mutex m;
  std::condition_variable cv;
  int written = 0;
  bool finished = false;
  std::set<std::string> expected = {"a"};
  std::thread writer([&] {
    try {
      for (int i = 0; i < 400; ++i) {
        h.upsert("n" + std::to_string(i), camera());
        std::lock_guard lock(m);
        expected.insert("n" + std::to_string(i));
        if (i % 3 == 2) {
          h.remove("n" + std::to_string(i - 1));
          expected.erase("n" + std::to_string(i - 1));
        }
        ++written;
        cv.notify_all();
      }
    } catch (const std::exception& e) {
      ADD_FAILURE() << e.what();
    }
    std::lock_guard lock(m);
    finished = true;
    cv.notify_all();
  });
  {
    std::unique_lock lock(m);
    cv.wait(lock, [&] { return written >= 20 || finished; });
  }
  WatchOptions o;
  o.initial(true);
  std::optional<Watch> w;
  EXPECT_NO_THROW(w.emplace(c.watch(o)));
  writer.join();
  ASSERT_TRUE(w);
  const auto last = h.command("domains []");  // the generation the writer left the table at
  std::map<std::string, bool> told;           // folded from the events: id -> synthetic
  const auto told_ids = [&] {
    std::set<std::string> ids;
    for (const auto& [id, synthetic] : told) ids.insert(id);
    return ids;
  };
  std::uint64_t previous = 0;
  for (int i = 0; i < 2000 && !(previous == last && told_ids() == expected); ++i) {
    auto e = next_event(*w);
    ASSERT_TRUE(e) << told.size() << " of " << expected.size() << " told";
    if (e->type == Event::Type::added) {
      EXPECT_FALSE(told.count(e->device.id)) << e->device.id << " added twice";
      told[e->device.id] = e->synthetic;
    } else if (e->type == Event::Type::removed) {
      EXPECT_TRUE(told.erase(e->device.id)) << e->device.id << " removed, never added";
    } else {
      ADD_FAILURE() << e->device.id << " changed";
    }
    EXPECT_GE(e->id, previous);  // in the table's order
    previous = e->id;
  }
  EXPECT_EQ(told_ids(), expected);
  EXPECT_TRUE(told.count("a") && told.at("a"));  // listed: a synthetic `added`, as asked for (initial)
  EXPECT_EQ(w->last_event_id(), last);

  auto g = h.upsert("b", camera());
  auto e = next_event(*w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->type, Event::Type::added);
  EXPECT_EQ(e->device.id, "b");
  EXPECT_EQ(e->id, g);
  EXPECT_FALSE(e->synthetic);
  g = h.upsert("b", camera({{"recovery", true}}));
  e = next_event(*w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->type, Event::Type::changed);
  EXPECT_TRUE(e->device.recovery);
  EXPECT_EQ(e->id, g);
  g = h.remove("a");
  e = next_event(*w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->type, Event::Type::removed);
  EXPECT_EQ(e->device.id, "a");
  EXPECT_EQ(w->last_event_id(), g);
  EXPECT_EQ(w->devices().size(), expected.size());  // a gone, b new
  EXPECT_FALSE(w->next(100ms));
}

TEST(Watch, ResumesWithLastEventIdAndRelistsOnResync) {
  Harness h({"--log-capacity", "3"});
  h.upsert("a", camera());
  h.upsert("b", camera());
  Client c(h.endpoint());
  Watch w = c.watch();
  auto g = h.upsert("c", camera());
  auto e = next_event(w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->device.id, "c");
  EXPECT_EQ(e->id, g);

  // The stream drops, and a camera comes before the watch is back: it resumes where
  // it stopped (Last-Event-ID) and hears of it as it happened. Had it re-listed, the
  // event would be synthetic; had it started from the newest event, it would not come.
  h.command("api-stop");
  g = h.upsert("e", camera());
  h.command("api-start");
  e = next_event(w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->type, Event::Type::added);
  EXPECT_EQ(e->device.id, "e");
  EXPECT_EQ(e->id, g);
  EXPECT_FALSE(e->synthetic);

  // Away longer, more changed than the change log keeps (3 events): the daemon cannot
  // replay, says so, and the watch re-lists and tells the difference: a gone, b changed,
  // d new. f came and went meanwhile; c and e did not change.
  h.command("api-stop");
  h.remove("a");
  h.upsert("b", camera({{"serial", "2"}}));
  h.upsert("d", camera());
  h.upsert("f", camera());
  const auto listed = h.remove("f");
  h.command("api-start");
  std::map<std::string, Event::Type> got;
  for (int i = 0; i < 3; ++i) {
    e = next_event(w);
    ASSERT_TRUE(e) << i;
    EXPECT_TRUE(e->synthetic);
    EXPECT_EQ(e->id, listed);
    got[e->device.id] = e->type;
  }
  EXPECT_EQ(got, (std::map<std::string, Event::Type>{
                     {"a", Event::Type::removed}, {"b", Event::Type::changed}, {"d", Event::Type::added}}));
  EXPECT_FALSE(w.next(100ms));
  EXPECT_EQ(w.last_event_id(), listed);
}

TEST(Watch, AResyncIsComparedWithTheCompleteListOnly) {
  Harness h;
  h.upsert("a", camera());
  h.upsert("b", camera());
  Client c(h.endpoint());
  Watch w = c.watch();
  // The daemon restarts: its table starts empty, at generations of its own, and its
  // first discovery takes a while. The watch's resume id is none of its: a resync.
  h.restart({"--first-generation", "1000", "--domains", kIncomplete});
  ASSERT_TRUE(h.wait_requests(kList, 2));  // the watch waits for the complete list
  // It hears every camera again (a with a new first-seen, b changed, c new); the
  // stream carries these while the list is awaited, and x comes and goes before it.
  h.upsert("a", camera());
  h.upsert("b", camera({{"serial", "2"}}));
  h.upsert("c", camera());
  h.upsert("x", camera());
  h.remove("x");
  const auto listed = h.command("domains " + kComplete);
  std::map<std::string, Event::Type> got;
  for (int i = 0; i < 2; ++i) {
    auto e = next_event(w);
    ASSERT_TRUE(e) << i;
    EXPECT_TRUE(e->synthetic);
    EXPECT_EQ(e->id, listed);
    got[e->device.id] = e->type;
  }
  EXPECT_EQ(got, (std::map<std::string, Event::Type>{{"b", Event::Type::changed}, {"c", Event::Type::added}}));
  // The partial lists, then the complete one (its log line may follow the answer).
  EXPECT_TRUE(h.wait_requests(kList, 3));
  const auto g = h.upsert("d", camera());
  auto e = next_event(w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->device.id, "d");
  EXPECT_EQ(e->id, g);
  EXPECT_FALSE(e->synthetic);
  EXPECT_FALSE(w.next(100ms));  // a was there before and after: nothing to tell
  EXPECT_EQ(w.devices().size(), 4u);
}

TEST(Watch, StopsPromptlyWhileWaitingForTheCompleteTable) {
  Harness h;
  Client c(h.endpoint());
  Watch w = c.watch();
  h.restart({"--first-generation", "1000", "--domains", kIncomplete});  // never completes
  ASSERT_TRUE(h.wait_requests(kList, 2));  // it is waiting
  const auto t0 = std::chrono::steady_clock::now();
  w.stop();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);
  EXPECT_FALSE(w.next(10ms));
}

TEST(Subscription, ACallbackThatThrowsReachesOnErrorAndWait) {
  Harness h;
  Client c(h.endpoint());
  std::mutex m;
  std::condition_variable cv;
  std::exception_ptr seen;
  auto sub = c.watch([](const Event&) { throw std::runtime_error("callback failed"); }, {},
                     [&](std::exception_ptr e) {
                       std::lock_guard lock(m);
                       seen = e;
                       cv.notify_all();
                     });
  h.upsert("x", camera());
  {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, 10s, [&] { return seen != nullptr; }));
  }
  EXPECT_THROW(sub.wait(), std::runtime_error);
  EXPECT_FALSE(sub.running());
}

TEST(Subscription, DeliversEventsAndStopsPromptly) {
  Harness h;
  Client c(h.endpoint());
  std::mutex m;
  std::condition_variable cv;
  std::vector<std::string> ids;
  auto sub = c.watch([&](const Event& e) {
    std::lock_guard lock(m);
    ids.push_back(e.device.id);
    cv.notify_all();
  });
  h.upsert("x", camera());
  const auto last = h.upsert("y", camera());
  {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, 10s, [&] { return ids.size() == 2; }));
    EXPECT_EQ(ids, (std::vector<std::string>{"x", "y"}));
  }
  auto t0 = std::chrono::steady_clock::now();
  sub.stop();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);
  EXPECT_FALSE(sub.running());
  EXPECT_EQ(sub.last_event_id(), last);
  sub.wait();  // no error
}

}  // namespace
