// Unit tests of the rsdiscovery client library: the pure parts (endpoints, SSE
// parsing, documents) and, against a scripted stand-in daemon on a Unix socket, the
// error paths the real daemon cannot be made to take (malformed replies, another API
// version) and the watch's resume/re-list logic, event by event.
#include "internal.hpp"

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
  EXPECT_EQ(Endpoint::parse("http://localhost/").port, 80);
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
}

// ---- SSE ------------------------------------------------------------------------------------

std::vector<detail::SseMessage> parse_sse(const std::string& text, std::size_t chunk) {
  std::vector<detail::SseMessage> out;
  detail::SseParser p([&](detail::SseMessage&& m) { out.push_back(std::move(m)); });
  for (std::size_t i = 0; i < text.size(); i += chunk) p.feed(std::string_view(text).substr(i, chunk));
  return out;
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

TEST(Device, UsbAndMergedDevices) {
  auto d = parse_device(R"({"id":"usb-2-1.3","sources":["usb","dds"],"usb":{"bus":2,"port-path":"2-1.3",
    "speed":"5000"},"warning":"serial differs"})");
  EXPECT_EQ(d.source, "usb");
  ASSERT_TRUE(d.usb);
  EXPECT_EQ(d.usb->bus, 2);
  EXPECT_EQ(d.usb->port_path, "2-1.3");
  EXPECT_EQ(d.warning, "serial differs");
  DeviceFilter f;
  f.source = "dds";
  EXPECT_TRUE(f.matches(d));
  f.domain = 3;
  EXPECT_FALSE(f.matches(d));
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

TEST(Device, SameDeviceIgnoresLastSeenOnly) {
  auto a = json::parse(R"({"id":"x","name":"n","last-seen":"1"})");
  auto b = json::parse(R"({"id":"x","name":"n","last-seen":"2"})");
  auto c = json::parse(R"({"id":"x","name":"m","last-seen":"2"})");
  EXPECT_TRUE(detail::same_device(a, b));
  EXPECT_FALSE(detail::same_device(a, c));
}

TEST(Filter, BuildsTheQueryWithEncoding) {
  DeviceFilter f;
  EXPECT_EQ(detail::devices_path(f), "/v1/devices");
  f.domain = 7;
  f.product_line = "D4 00&x";
  f.source = "usb";
  EXPECT_EQ(detail::devices_path(f), "/v1/devices?domain=7&product-line=D4%2000%26x&source=usb");
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
      res.set_content(R"({"status":"ok","version":"9.9.9","devices":0})", "application/json");
    });
    server_.Get("/v1/devices", [this](const httplib::Request& req, httplib::Response& res) {
      std::lock_guard lock(m_);
      ++lists_;
      last_list_query_ = req.params.size();
      res.status = list_status_;
      res.set_content(list_body_, "application/json");
    });
    server_.Get(R"(/v1/devices/(.+))", [](const httplib::Request& req, httplib::Response& res) {
      if (req.matches[1] == "known") {
        res.set_content(R"({"id":"known","name":"N"})", "application/json");
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
