// The API's event loops (ServerLoop and its reactors) over socketpairs, as
// dbus-broker tests its socket layer: one end given to the loop, the test the
// client on the other. A request is answered on its connection, a response far
// larger than the socket's buffer arrives whole (sendfile and the splice pipe
// under a slow reader), and a stop answers every connection it accepted.
#include "api/server_loop.hpp"
#include "body_pattern.hpp"

#include <gtest/gtest.h>

#include <future>
#include <string>
#include <thread>

#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

namespace {

using namespace std::chrono_literals;
using rsd::api::LoopListener;
using rsd::api::LoopOptions;
using rsd::api::RequestServer;
using rsd::api::ServerLoop;
using rsd::api::SharedBody;

// The client's end: blocking, with a receive timeout that only bounds a failure.
struct Client {
  int fd = -1;
  explicit Client(int f) : fd(f) {
    timeval tv{10, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  }
  ~Client() {
    if (fd >= 0) ::close(fd);
  }
  void send(const std::string& bytes) const {
    ASSERT_EQ(::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL), static_cast<ssize_t>(bytes.size()));
  }
  // One response: its head, and its body by Content-Length; "" on end of file.
  std::pair<std::string, std::string> response(std::size_t read_size = 65536) {
    std::string head, body;
    while (head.find("\r\n\r\n") == std::string::npos) {
      char c;
      if (::recv(fd, &c, 1, 0) != 1) return {head, body};
      head += c;
    }
    const auto cl = head.find("Content-Length: ");
    if (cl == std::string::npos) return {head, body};
    const auto length = std::stoul(head.substr(cl + 16));
    std::string buf(read_size, '\0');
    while (body.size() < length) {
      const auto n = ::recv(fd, buf.data(), std::min(buf.size(), length - body.size()), 0);
      if (n <= 0) break;
      body.append(buf.data(), static_cast<std::size_t>(n));
    }
    return {head, body};
  }
  bool at_eof() const {
    char c;
    return ::recv(fd, &c, 1, 0) == 0;
  }
};

// A loop of two reactors with one Unix-socket and one "TCP" name for socketpairs.
struct Loop {
  RequestServer unix_server{0}, http_server{0};
  std::unique_ptr<ServerLoop> loop;
  std::shared_ptr<const SharedBody> big = std::make_shared<const SharedBody>(body_pattern(2 * 1024 * 1024));
  std::promise<void> slow_entered, slow_release;
  std::shared_future<void> release = slow_release.get_future().share();

  Loop() {
    for (auto* svr : {&unix_server, &http_server}) {
      svr->Get("/hello", [](const httplib::Request&, httplib::Response& res) { res.set_content("hi", "text/plain"); });
      svr->Get("/big", [this](const httplib::Request&, httplib::Response& res) {
        auto body = big;
        res.set_content_provider(body->bytes().size(), "application/octet-stream",
                                 [body](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                                   return rsd::api::write_shared(sink, body, offset, length);
                                 });
      });
      svr->Get("/slow", [this](const httplib::Request&, httplib::Response& res) {
        slow_entered.set_value();
        release.wait();
        res.set_content("slow", "text/plain");
      });
    }
    LoopOptions o;
    o.threads = 2;
    o.blocking_threads = 1;
    o.blocking = [](std::string_view target) { return target == "/slow"; };
    loop = std::make_unique<ServerLoop>(o);
    LoopListener u, h;
    u.server = &unix_server;
    u.name = "unix";
    h.server = &http_server;
    h.http = true;
    h.name = "http";
    loop->start({u, h});
  }
  // A connection to listener `which`: the loop gets one end, the test the other.
  std::unique_ptr<Client> connect(std::size_t which = 0) {
    int fds[2];
    EXPECT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds), 0);
    const int small = 4096;  // far below the big body: every send stops part way
    ::setsockopt(fds[0], SOL_SOCKET, SO_SNDBUF, &small, sizeof small);
    ::setsockopt(fds[1], SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
    loop->adopt(fds[0], which);
    return std::make_unique<Client>(fds[1]);
  }
};

const std::string kHello = "GET /hello HTTP/1.1\r\nHost: localhost\r\n\r\n";

TEST(Reactor, ARequestWrittenToAConnectionIsAnsweredOnIt) {
  Loop l;
  auto a = l.connect();
  auto b = l.connect();
  for (int round = 0; round < 3; ++round) {  // kept alive between requests
    for (auto* c : {a.get(), b.get()}) {
      c->send(kHello);
      const auto [head, body] = c->response();
      EXPECT_EQ(head.rfind("HTTP/1.1 200", 0), 0u) << head;
      EXPECT_EQ(body, "hi");
    }
  }
  // Pipelined, split at an awkward place: both answered, in order.
  a->send(kHello + kHello.substr(0, 7));
  a->send(kHello.substr(7));
  EXPECT_EQ(a->response().second, "hi");
  EXPECT_EQ(a->response().second, "hi");
  EXPECT_EQ(l.loop->stats().connections, 2u);
  l.loop->stop(1000ms);
  EXPECT_TRUE(a->at_eof());
  EXPECT_EQ(l.loop->stats().connections, 0u);
}

TEST(Reactor, AResponseLargerThanTheSocketBufferArrivesWhole) {
  Loop l;
  ASSERT_GE(l.big->fd(), 0) << "the body should sit in a memfd";
  for (std::size_t which : {0u, 1u}) {  // the splice pipe (Unix socket), sendfile (TCP)
    auto c = l.connect(which);
    for (int round = 0; round < 2; ++round) {
      c->send("GET /big HTTP/1.1\r\nHost: localhost\r\n\r\n");
      const auto [head, body] = c->response(1000);  // a slow reader: small reads
      EXPECT_EQ(head.rfind("HTTP/1.1 200", 0), 0u) << head;
      ASSERT_EQ(body.size(), l.big->bytes().size()) << "listener " << which;
      EXPECT_TRUE(body == l.big->bytes()) << "bytes out of order, listener " << which;
    }
    c->send(kHello);  // the connection is still in step after it
    EXPECT_EQ(c->response().second, "hi");
  }
  l.loop->stop(1000ms);
}

TEST(Reactor, StopAnswersEveryConnectionWithARequestInFlight) {
  Loop l;
  auto idle = l.connect();
  idle->send(kHello);
  ASSERT_EQ(idle->response().second, "hi");  // now an idle keep-alive
  auto parked = l.connect();
  parked->send("GET /slow HTTP/1.1\r\nHost: localhost\r\n\r\n");
  l.slow_entered.get_future().wait();  // on the blocking pool when the stop begins
  auto late = l.connect(1);
  late->send(kHello);  // written, perhaps not yet read, when the stop begins

  std::thread stopper([&] { l.loop->stop(10000ms); });
  EXPECT_TRUE(idle->at_eof()) << "an idle keep-alive is closed at once";
  const auto [late_head, late_body] = late->response();
  EXPECT_EQ(late_body, "hi") << late_head;
  l.slow_release.set_value();
  const auto [head, body] = parked->response();
  EXPECT_EQ(head.rfind("HTTP/1.1 200", 0), 0u) << head;
  EXPECT_EQ(body, "slow");
  EXPECT_TRUE(parked->at_eof());
  stopper.join();
  EXPECT_EQ(l.loop->stats().connections, 0u);
}

}  // namespace

// The default number of loops: one for every two CPUs the daemon may run on, so that
// on a small host its clients keep a core; never none, and never more than two.
TEST(ServerLoop, LoopThreadsAreOneForEveryTwoCpusFromOneToTwo) {
  EXPECT_EQ(rsd::api::loop_threads_for(0), 1);
  EXPECT_EQ(rsd::api::loop_threads_for(1), 1);
  EXPECT_EQ(rsd::api::loop_threads_for(2), 1);
  EXPECT_EQ(rsd::api::loop_threads_for(3), 1);
  EXPECT_EQ(rsd::api::loop_threads_for(4), 2);
  EXPECT_EQ(rsd::api::loop_threads_for(64), 2);
}
