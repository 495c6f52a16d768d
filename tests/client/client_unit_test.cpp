// Unit tests of the rsdiscovery client library: the pure parts (endpoints, SSE
// parsing, documents) and, against a scripted stand-in daemon on a Unix socket, the
// error paths the real daemon cannot be made to take (malformed replies, another API
// version) and the watch's resume/re-list logic, event by event.
#include "internal.hpp"
#include "rsd_model/status.hpp"
#include "table/device_table.hpp"
#include "usb/usb_device.hpp"

#include <rsdiscovery/rsdiscovery.hpp>

#include <gtest/gtest.h>
#include <httplib.h>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>

using namespace rsdiscovery;
using namespace std::chrono_literals;
using nlohmann::json;

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
  EXPECT_EQ(json::parse(d.json)["fw-version"], "5.16.0.1");
}

TEST(Device, ListSlicesAreEachDeviceExactlyAsSent) {
  // What Client::list keeps as Device::json: each element of "devices" cut out of
  // the reply, so it must be the element whatever its strings hold.
  json list = {{"complete", true},
               {"a-before", json::array({json::array({1, 2}), "x]", json::object({{"k", "}"}})})},
               {"devices", json::array({json::object({{"id", "a\"b\\"}, {"name", "quote \" [brace] {x}"}}),
                                        json::object({{"id", "c"}, {"nested", {{"deep", json::array({1, "2", nullptr})}}}}),
                                        json::object({{"id", "\\\\"}, {"name", "caf\u00e9 \u2014 \\\""}})})},
               {"generation", 42}};
  for (const std::string& text : {list.dump(), list.dump(2)}) {  // compact, as the daemon writes, and spaced
    const auto slices = detail::array_member_elements(text, "devices");
    ASSERT_EQ(slices.size(), 3u) << text;
    for (std::size_t i = 0; i < slices.size(); ++i) EXPECT_EQ(json::parse(slices[i]), list["devices"][i]);
  }
  EXPECT_EQ(detail::array_member_elements(json({{"devices", json::array()}}).dump(), "devices").size(), 0u);
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

// Client::list reads with RapidJSON (device_list.cpp), everything else with nlohmann:
// the same document must give the same devices either way, and the same documents must
// be refused.
void expect_same_device(const Device& a, const Device& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.sources, b.sources);
  EXPECT_EQ(a.domain, b.domain);
  EXPECT_EQ(a.topic_root, b.topic_root);
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.serial, b.serial);
  EXPECT_EQ(a.product_line, b.product_line);
  EXPECT_EQ(a.product_id, b.product_id);
  EXPECT_EQ(a.fw_version, b.fw_version);
  EXPECT_EQ(a.recovery, b.recovery);
  EXPECT_EQ(a.first_seen, b.first_seen);
  EXPECT_EQ(a.last_seen, b.last_seen);
  EXPECT_EQ(a.state, b.state);
  EXPECT_EQ(a.warnings, b.warnings);
  EXPECT_EQ(a.warning, b.warning);
  ASSERT_EQ(a.server.has_value(), b.server.has_value());
  if (a.server) {
    EXPECT_EQ(a.server->participant_guid, b.server->participant_guid);
    EXPECT_EQ(a.server->participant_name, b.server->participant_name);
    EXPECT_EQ(a.server->addresses, b.server->addresses);
  }
  ASSERT_EQ(a.usb.has_value(), b.usb.has_value());
  if (a.usb) {
    EXPECT_EQ(a.usb->bus, b.usb->bus);
    EXPECT_EQ(a.usb->port_path, b.usb->port_path);
    EXPECT_EQ(a.usb->speed, b.usb->speed);
  }
  EXPECT_EQ(a.json, b.json);
}

TEST(DeviceList, ReadsTheDaemonsListAsNlohmannReadsEachDevice) {
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
                {"numbers", json::array({-1, 18446744073709551615ULL, 1.5, 1e300, 0})},
                {"server", {{"participant-guid", "01.0f"}, {"addresses", json::array({"192.0.2.1", "10.1.2.3"})}}}},
               "2026-11-23T13:10:21.000Z");
  table.upsert("dds-8-realsense.D405_2",
               {{"source", "dds"}, {"domain", "eight"}, {"serial", 2}, {"name", "a \"quoted\" \\ name\n"},
                {"fw-version", nullptr}, {"server", {{"participant-guid", 5}}}, {"warnings", json::array()}},
               "2026-11-23T13:10:22.000Z");
  const json list = {{"generation", 9}, {"complete", false}, {"devices", table.devices()}};
  for (const std::string& text : {list.dump(), list.dump(2)}) {
    std::string body = text;
    DeviceList out;
    ASSERT_EQ(detail::read_device_list(body, "/v1/devices", out), std::nullopt) << text;
    EXPECT_EQ(out.generation, 9u);
    EXPECT_FALSE(out.complete);
    const auto slices = detail::array_member_elements(text, "devices");
    ASSERT_EQ(out.devices.size(), 4u);
    for (std::size_t i = 0; i < out.devices.size(); ++i) {
      SCOPED_TRACE(i);
      expect_same_device(out.devices[i], detail::device_from_json(list["devices"][i], std::string(slices[i])));
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

TEST(DeviceList, RefusesWhatNlohmannRefuses) {
  const std::string bad_utf8[] = {"\xff", "\xc0\xaf", "\xed\xa0\x80", "caf\xc3"};  // stray, overlong, surrogate, cut
  std::vector<std::string> bodies = {
      "", "{", R"({"devices":[]} x)", R"({"devices":[1e400]})", R"({"devices":["\ud800"]})",
      "{\"devices\":[\"a\x01\"]}", R"({"devices":[{"id":"a",}]})", R"({"devices":[NaN]})", R"({'devices':[]})",
      R"({"devices":[01]})"};
  for (const auto& b : bad_utf8) bodies.push_back(R"({"devices":[{"id":"x","name":")" + b + R"("}]})");
  for (const auto& text : bodies) {
    SCOPED_TRACE(text);
    EXPECT_TRUE(json::parse(text, nullptr, false).is_discarded());  // nlohmann's verdict
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
  // Exponents of more than three digits (which the daemon never writes) are read by
  // nlohmann, never by bookworm's RapidJSON (CVE-2024-38517): as nlohmann reads them
  // (0), and refused where nlohmann refuses them.
  std::string tiny = R"({"devices":[{"id":"x","n":[0.00001e-2147483647,1.5e-2147483648,1e-99999]}]})";
  ASSERT_EQ(detail::read_device_list(tiny, "/v1/devices", out), std::nullopt);
  EXPECT_EQ(json::parse(out.devices.at(0).field("n")), json::parse("[0.0,0.0,0.0]"));
  std::string huge = R"({"devices":[{"id":"x","n":1e2147483647}]})";
  EXPECT_EQ(detail::read_device_list(huge, "/v1/devices", out), "GET /v1/devices did not return a JSON object");
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
  auto d = detail::device_from_json(table.devices().at(0));
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
                {"name", "Intel RealSense D435"}, {"recovery", false}, {"server", json::object()}},
               "2026-11-23T13:10:21.000Z");
  auto merged = detail::device_from_json(table.devices().at(0));
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
  auto a = json::parse(R"({"id":"x","name":"n","last-seen":"1","first-seen":"1"})");
  auto b = json::parse(R"({"id":"x","name":"n","last-seen":"2","first-seen":"1"})");
  auto c = json::parse(R"({"id":"x","name":"m","last-seen":"2","first-seen":"1"})");
  // A restarted daemon sets first-seen anew for a camera that never went away.
  auto d = json::parse(R"({"id":"x","name":"n","last-seen":"1","first-seen":"9"})");
  EXPECT_TRUE(detail::same_device(a, b));
  EXPECT_FALSE(detail::same_device(a, c));
  EXPECT_TRUE(detail::same_device(a, d));
}

TEST(Device, CompleteUnlessTheDocumentSaysOtherwise) {
  EXPECT_TRUE(detail::reports_complete(json::parse(R"({"devices":[]})")));  // an older daemon
  EXPECT_TRUE(detail::reports_complete(json::parse(R"({"complete":true})")));
  EXPECT_FALSE(detail::reports_complete(json::parse(R"({"complete":false})")));
  // The daemon's own documents (the shared model writes them), still settling.
  rsd::model::Health health;
  health.complete = false;
  EXPECT_FALSE(detail::health_from_json(rsd::model::to_json(health)).complete);
  rsd::model::DomainStatus domain;
  domain.domain = 1;
  domain.state = rsd::model::DomainState::settling;
  EXPECT_FALSE(detail::domain_from_json(rsd::model::to_json(domain)).complete);
  domain.complete = true;
  domain.state = rsd::model::DomainState::running;
  const auto running = detail::domain_from_json(rsd::model::to_json(domain));
  EXPECT_TRUE(running.complete);
  EXPECT_EQ(running.state, "running");
  // What is not the daemon's document is named, not half read.
  EXPECT_THROW(detail::domain_from_json(json::parse(R"({"domain":1,"complete":false})")), Error);
  EXPECT_THROW(detail::health_from_json(json::parse(R"({"status":"ok"})")), Error);
}

TEST(Filter, BuildsTheQueryWithEncoding) {
  DeviceFilter f;
  EXPECT_EQ(detail::devices_path(f), "/v1/devices");
  f.domain = 7;
  f.product_line = "D4 00&x";
  f.source = "usb";
  EXPECT_EQ(detail::devices_path(f), "/v1/devices?domain=7&product-line=D4%2000%26x&source=usb");
  DeviceFilter more;
  more.domains = {1, 2};
  more.serial = "ab12";
  more.name = "D455 ";
  more.address = "192.0.2.2";
  EXPECT_EQ(detail::devices_path(more), "/v1/devices?domain=1&domain=2&serial=ab12&name=D455%20&address=192.0.2.2");
}

// ---- a scripted stand-in daemon ---------------------------------------------------------------

class FakeDaemon {
 public:
  FakeDaemon() {
    dir_ = std::filesystem::temp_directory_path() / ("rsd-client-unit-" + std::to_string(getpid()) + "-" +
                                                     std::to_string(counter_++));
    std::filesystem::create_directories(dir_);
    path_ = (dir_ / "api.sock").string();
    server_.set_address_family(AF_UNIX);
    server_.Get("/healthz", [](const httplib::Request&, httplib::Response& res) {
      rsd::model::Health health;
      health.version = "9.9.9";
      health.complete = true;
      res.set_content(rsd::model::to_json(health).dump(), "application/json");
    });
    server_.Get("/v1/devices", [this](const httplib::Request& req, httplib::Response& res) {
      std::lock_guard lock(m_);
      ++lists_;
      last_list_query_ = req.params.size();
      res.status = list_status_;
      if (lists_until_later_ > 0 && --lists_until_later_ == 0) list_body_ = list_later_body_;
      res.set_content(list_body_, "application/json");
    });
    server_.Get(R"(/v1/devices/(.+))", [this](const httplib::Request& req, httplib::Response& res) {
      std::lock_guard lock(m_);
      if (req.matches[1] == "known") {
        res.set_content(R"({"id":"known","name":"N"})", "application/json");
      } else if (req.matches[1] == "later" && gets_until_later_ > 0) {
        // A camera the daemon has not heard from yet: its first discovery still runs.
        --gets_until_later_;
        res.status = 404;
        res.set_content(R"({"error":"no such device","status":404,"complete":false})", "application/json");
      } else if (req.matches[1] == "later") {
        res.set_content(R"({"id":"later","name":"L"})", "application/json");
      } else {
        res.status = 404;
        res.set_content(R"({"error":"no such device","status":404})", "application/json");
      }
    });
    server_.Get("/v1/events", [this](const httplib::Request& req, httplib::Response& res) {
      {
        std::lock_guard lock(m_);
        last_event_ids_.push_back(req.get_header_value("Last-Event-ID"));
      }
      cv_.notify_all();
      res.set_chunked_content_provider("text/event-stream", [this](std::size_t, httplib::DataSink& sink) {
        std::unique_lock lock(m_);
        cv_.wait_for(lock, 20ms, [this] { return !events_.empty() || close_streams_; });
        if (close_streams_) {
          close_streams_ = false;
          return false;  // drops the connection
        }
        while (!events_.empty()) {
          std::string e = std::move(events_.front());
          events_.pop_front();
          if (!sink.write(e.data(), e.size())) return false;
        }
        return !stopping_;
      });
    });
    if (!server_.bind_to_port(path_, 80)) throw std::runtime_error("cannot bind " + path_);
    thread_ = std::thread([this] { server_.listen_after_bind(); });
    while (!server_.is_running()) std::this_thread::sleep_for(1ms);
  }
  ~FakeDaemon() {
    stopping_ = true;
    server_.stop();
    thread_.join();
    std::filesystem::remove_all(dir_);
  }
  std::string endpoint() const { return "unix:" + path_; }
  void set_list(int status, std::string body) {
    std::lock_guard lock(m_);
    list_status_ = status;
    list_body_ = std::move(body);
    lists_until_later_ = 0;
  }
  // `body` answers the next `after` lists, `later` every one after them (a daemon
  // whose first discovery ends meanwhile).
  void set_list_then(std::string body, int after, std::string later) {
    std::lock_guard lock(m_);
    list_status_ = 200;
    list_body_ = std::move(body);
    list_later_body_ = std::move(later);
    lists_until_later_ = after + 1;
  }
  int lists() {
    std::lock_guard lock(m_);
    return lists_;
  }
  // GET /v1/devices/later: 404 with "complete": false `n` times, then the device.
  void set_later_after(int n) {
    std::lock_guard lock(m_);
    gets_until_later_ = n;
  }
  void send(const std::string& event, std::uint64_t id, const std::string& data) {
    {
      std::lock_guard lock(m_);
      events_.push_back("event: " + event + "\nid: " + std::to_string(id) + "\ndata: " + data + "\n\n");
    }
    cv_.notify_all();
  }
  void drop_streams() {
    {
      std::lock_guard lock(m_);
      close_streams_ = true;
    }
    cv_.notify_all();
  }
  // Waits until the n-th event stream request came; returns its Last-Event-ID.
  std::string wait_stream(std::size_t n) {
    std::unique_lock lock(m_);
    if (!cv_.wait_for(lock, 5s, [&] { return last_event_ids_.size() >= n; })) return "<timeout>";
    return last_event_ids_[n - 1];
  }

 private:
  static inline std::atomic<int> counter_{0};
  std::filesystem::path dir_;
  std::string path_;
  httplib::Server server_;
  std::thread thread_;
  std::mutex m_;
  std::condition_variable cv_;
  int list_status_ = 200;
  std::string list_body_ = R"({"generation":10,"devices":[]})";
  int lists_ = 0;
  int lists_until_later_ = 0;
  std::string list_later_body_;
  int gets_until_later_ = 0;
  std::size_t last_list_query_ = 0;
  std::deque<std::string> events_;
  std::vector<std::string> last_event_ids_;
  bool close_streams_ = false;
  std::atomic<bool> stopping_{false};
};

std::string dev(const std::string& id, const std::string& extra = "") {
  return R"({"id":")" + id + R"(","name":"Intel RealSense D455","source":"dds","domain":7)" + extra + "}";
}

ErrorCode code_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.code();
  }
  return ErrorCode::cancelled;  // "no error" marker for these tests
}

TEST(Client, ListsAndGets) {
  FakeDaemon fake;
  fake.set_list(200, R"({"generation":3,"devices":[)" + dev("a") + "," + dev("b") + "]}");
  Client c(fake.endpoint());
  auto list = c.list_devices();
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[1].id, "b");
  EXPECT_EQ(c.get_device("known").name, "N");
  EXPECT_FALSE(c.find_device("unknown"));
  EXPECT_EQ(code_of([&] { c.get_device("unknown"); }), ErrorCode::not_found);
  EXPECT_EQ(c.health().version, "9.9.9");
}

TEST(Client, ListWaitsForTheCompleteTable) {
  FakeDaemon fake;
  const std::string partial = R"({"generation":3,"complete":false,"devices":[]})";
  const std::string whole = R"({"generation":5,"complete":true,"devices":[)" + dev("a") + "]}";
  fake.set_list_then(partial, 3, whole);
  Client c(fake.endpoint());
  auto l = c.list();
  EXPECT_TRUE(l.complete);
  EXPECT_EQ(l.generation, 5u);
  ASSERT_EQ(l.devices.size(), 1u);
  EXPECT_EQ(l.devices[0].id, "a");
  EXPECT_EQ(fake.lists(), 4);  // asked again until complete

  // Told not to wait: the partial answer, said to be partial.
  fake.set_list_then(partial, 3, whole);
  ClientOptions now;
  now.complete_timeout = 0ms;
  l = Client(fake.endpoint(), now).list();
  EXPECT_FALSE(l.complete);
  EXPECT_TRUE(l.devices.empty());

  // The wait is bounded: a table that never completes is answered from after the bound.
  fake.set_list(200, partial);
  ClientOptions brief;
  brief.complete_timeout = 200ms;
  const auto t0 = std::chrono::steady_clock::now();
  l = Client(fake.endpoint(), brief).list();
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_FALSE(l.complete);
  EXPECT_GE(took, 200ms);
  EXPECT_LT(took, 2s);

  // A daemon older than the field has nothing to wait for.
  fake.set_list(200, R"({"generation":7,"devices":[]})");
  const int before = fake.lists();
  EXPECT_TRUE(c.list().complete);
  EXPECT_EQ(fake.lists(), before + 1);
}

TEST(Client, FindWaitsForACameraWhileTheTableIsIncomplete) {
  FakeDaemon fake;
  fake.set_later_after(3);
  Client c(fake.endpoint());
  auto d = c.find_device("later");
  ASSERT_TRUE(d);
  EXPECT_EQ(d->name, "L");
  fake.set_later_after(3);
  ClientOptions now;
  now.complete_timeout = 0ms;
  EXPECT_FALSE(Client(fake.endpoint(), now).find_device("later"));
  // A 404 from a complete table (or one that does not say) is final at once.
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(code_of([&] { c.get_device("unknown"); }), ErrorCode::not_found);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);
}

TEST(Client, MalformedRepliesAreNamed) {
  FakeDaemon fake;
  Client c(fake.endpoint());
  for (const char* body : {"not json", "[]", R"({"devices":5})", R"({"devices":[{"name":"no id"}]})"}) {
    fake.set_list(200, body);
    try {
      c.list_devices();
      ADD_FAILURE() << body;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::malformed_reply) << body;
      EXPECT_NE(std::string(e.what()).find("malformed reply"), std::string::npos) << e.what();
    }
  }
}

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

TEST(Client, AnotherApiVersionIsAVersionMismatch) {
  FakeDaemon fake;
  fake.set_list(404, R"({"error":"unknown path","status":404})");
  Client c(fake.endpoint());
  try {
    c.list_devices();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::version_mismatch);
    std::string what = e.what();
    EXPECT_NE(what.find("version mismatch"), std::string::npos) << what;
    EXPECT_NE(what.find("9.9.9"), std::string::npos) << what;  // the daemon's version, from /healthz
  }
  fake.set_list(500, R"({"error":"boom","status":500})");
  EXPECT_EQ(code_of([&] { c.list_devices(); }), ErrorCode::http_error);
}

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

std::optional<Event> next_event(Watch& w) { return w.next(5s); }

TEST(Watch, StreamsFromTheListsGenerationAndDropsReplays) {
  FakeDaemon fake;
  fake.set_list(200, R"({"generation":10,"devices":[)" + dev("a") + "]}");
  Client c(fake.endpoint());
  WatchOptions o;
  o.initial = true;
  Watch w = c.watch(o);
  EXPECT_EQ(fake.wait_stream(1), "10");  // no gap between the list and the stream
  auto e = next_event(w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->type, Event::Type::added);
  EXPECT_TRUE(e->synthetic);
  EXPECT_EQ(e->device.id, "a");
  fake.send("added", 11, dev("a"));  // already listed: not news
  fake.send("added", 12, dev("b"));
  e = next_event(w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->device.id, "b");
  EXPECT_EQ(e->id, 12u);
  EXPECT_FALSE(e->synthetic);
  fake.send("changed", 13, dev("b", R"(,"recovery":true)"));
  e = next_event(w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->type, Event::Type::changed);
  EXPECT_TRUE(e->device.recovery);
  fake.send("removed", 14, dev("zzz"));  // never seen: nothing to report
  fake.send("removed", 15, dev("a"));
  e = next_event(w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->type, Event::Type::removed);
  EXPECT_EQ(e->device.id, "a");
  EXPECT_EQ(w.last_event_id(), 15u);
  EXPECT_EQ(w.devices().size(), 1u);
}

TEST(Watch, ResumesWithLastEventIdAndRelistsOnResync) {
  FakeDaemon fake;
  fake.set_list(200, R"({"generation":10,"devices":[)" + dev("a") + "," + dev("b") + "]}");
  Client c(fake.endpoint());
  Watch w = c.watch();
  ASSERT_EQ(fake.wait_stream(1), "10");
  fake.send("added", 20, dev("c"));
  ASSERT_TRUE(next_event(w));
  fake.drop_streams();
  EXPECT_EQ(fake.wait_stream(2), "20");  // resumed where it stopped
  // The daemon restarted meanwhile: it cannot replay, says so; the list now lacks a,
  // has a changed b, and a new d.
  fake.set_list(200, R"({"generation":1000,"devices":[)" + dev("b", R"(,"serial":"2")") + "," + dev("c") + "," +
                         dev("d") + "]}");
  fake.send("resync", 999, R"({"generation":999})");
  std::map<std::string, Event::Type> got;
  for (int i = 0; i < 3; ++i) {
    auto e = next_event(w);
    ASSERT_TRUE(e) << i;
    EXPECT_TRUE(e->synthetic);
    EXPECT_EQ(e->id, 1000u);
    got[e->device.id] = e->type;
  }
  EXPECT_EQ(got["a"], Event::Type::removed);
  EXPECT_EQ(got["b"], Event::Type::changed);
  EXPECT_EQ(got["d"], Event::Type::added);
  EXPECT_FALSE(w.next(100ms));  // c was known and unchanged
  EXPECT_EQ(w.last_event_id(), 1000u);
}

TEST(Watch, AResyncIsComparedWithTheCompleteListOnly) {
  FakeDaemon fake;
  fake.set_list(200, R"({"generation":10,"complete":true,"devices":[)" + dev("a", R"(,"first-seen":"1")") + "," +
                         dev("b") + "]}");
  Client c(fake.endpoint());
  Watch w = c.watch();
  ASSERT_EQ(fake.wait_stream(1), "10");
  // A restarted daemon: its first answers lack every camera, then it has heard them
  // all again (a with a new first-seen, b changed, c new).
  fake.set_list_then(R"({"generation":1000,"complete":false,"devices":[]})", 3,
                     R"({"generation":1003,"complete":true,"devices":[)" + dev("a", R"(,"first-seen":"2")") + "," +
                         dev("b", R"(,"serial":"2")") + "," + dev("c") + "]}");
  fake.send("resync", 999, R"({"generation":999})");
  // What the stream carried while the list was awaited is in that list already; x
  // came and went before it.
  fake.send("added", 1001, dev("a", R"(,"first-seen":"2")"));
  fake.send("added", 1002, dev("x"));
  fake.send("removed", 1003, dev("x"));
  std::map<std::string, Event::Type> got;
  for (int i = 0; i < 2; ++i) {
    auto e = next_event(w);
    ASSERT_TRUE(e) << i;
    EXPECT_TRUE(e->synthetic);
    EXPECT_EQ(e->id, 1003u);
    got[e->device.id] = e->type;
  }
  EXPECT_EQ(got, (std::map<std::string, Event::Type>{{"b", Event::Type::changed}, {"c", Event::Type::added}}));
  EXPECT_GE(fake.lists(), 5);  // the first list, then the partial ones and the complete one
  fake.send("added", 1004, dev("d"));
  auto e = next_event(w);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->device.id, "d");
  EXPECT_FALSE(e->synthetic);
  EXPECT_FALSE(w.next(100ms));  // a was there before and after: nothing to tell
  EXPECT_EQ(w.devices().size(), 4u);
}

TEST(Watch, StopsPromptlyWhileWaitingForTheCompleteTable) {
  FakeDaemon fake;
  fake.set_list(200, R"({"generation":10,"complete":true,"devices":[]})");
  Client c(fake.endpoint());
  Watch w = c.watch();
  ASSERT_EQ(fake.wait_stream(1), "10");
  fake.set_list(200, R"({"generation":11,"complete":false,"devices":[]})");  // never completes
  const int before = fake.lists();
  fake.send("resync", 11, R"({"generation":11})");
  for (int i = 0; i < 500 && fake.lists() < before + 2; ++i) std::this_thread::sleep_for(10ms);
  ASSERT_GE(fake.lists(), before + 2);  // it is waiting
  const auto t0 = std::chrono::steady_clock::now();
  w.stop();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);
  EXPECT_FALSE(w.next(10ms));
}

TEST(Watch, FailsAtOnceWhenTheDaemonIsAbsent) {
  Client c(Endpoint::parse("unix:/nonexistent-dir/rsd.sock"));
  EXPECT_EQ(code_of([&] { c.watch(); }), ErrorCode::not_running);
}

TEST(Watch, MalformedEventsEndTheWatchWithAnError) {
  FakeDaemon fake;
  Client c(fake.endpoint());
  Watch w = c.watch();
  ASSERT_EQ(fake.wait_stream(1), "10");
  fake.send("added", 11, "{not json");
  EXPECT_EQ(code_of([&] { w.next(5s); }), ErrorCode::malformed_reply);
}

TEST(Subscription, ACallbackThatThrowsReachesOnErrorAndWait) {
  FakeDaemon fake;
  Client c(fake.endpoint());
  std::mutex m;
  std::condition_variable cv;
  std::exception_ptr seen;
  auto sub = c.watch([](const Event&) { throw std::runtime_error("callback failed"); }, {},
                     [&](std::exception_ptr e) {
                       std::lock_guard lock(m);
                       seen = e;
                       cv.notify_all();
                     });
  ASSERT_EQ(fake.wait_stream(1), "10");
  fake.send("added", 11, dev("x"));
  {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, 5s, [&] { return seen != nullptr; }));
  }
  EXPECT_THROW(sub.wait(), std::runtime_error);
  EXPECT_FALSE(sub.running());
}

TEST(Subscription, DeliversEventsAndStopsPromptly) {
  FakeDaemon fake;
  Client c(fake.endpoint());
  std::mutex m;
  std::condition_variable cv;
  std::vector<std::string> ids;
  auto sub = c.watch([&](const Event& e) {
    std::lock_guard lock(m);
    ids.push_back(e.device.id);
    cv.notify_all();
  });
  ASSERT_EQ(fake.wait_stream(1), "10");
  fake.send("added", 11, dev("x"));
  fake.send("added", 12, dev("y"));
  {
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, 5s, [&] { return ids.size() == 2; }));
  }
  auto t0 = std::chrono::steady_clock::now();
  sub.stop();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);
  EXPECT_FALSE(sub.running());
  EXPECT_EQ(sub.last_event_id(), 12u);
  sub.wait();  // no error
}

}  // namespace
