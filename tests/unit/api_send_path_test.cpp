// The API's send path, driven over socketpairs with a small send buffer so that
// every call stops part way, as a slow client makes it: SharedBody's sealed memfd and
// pipe, and send_pending through the splice pipe (Unix socket) and sendfile (TCP) alike.
// Until the server loop was split these were reached only through the daemon; and
// a ServerLoop whose start fails.
#include "api/connection.hpp"
#include "body_pattern.hpp"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <string>

namespace {

using rsd::api::Clock;
using rsd::api::Connection;
using rsd::api::LoopListener;
using rsd::api::SharedBody;

struct Pair {
  int daemon = -1, client = -1;
  Pair() {
    int fds[2];
    EXPECT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0, fds), 0);
    daemon = fds[0];
    client = fds[1];
    const int small = 4096;  // the kernel doubles it; still far below the bodies here
    ::setsockopt(daemon, SOL_SOCKET, SO_SNDBUF, &small, sizeof small);
    ::setsockopt(client, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  }
  ~Pair() {
    if (daemon >= 0) ::close(daemon);
    if (client >= 0) ::close(client);
  }
  std::string read_available() const {
    std::string got;
    char buf[8192];
    ssize_t n;
    while ((n = ::recv(client, buf, sizeof buf, MSG_DONTWAIT)) > 0) got.append(buf, static_cast<std::size_t>(n));
    return got;
  }
};

// Sends `head` then `body` on a connection of `listener` to a client that reads
// what is there between calls; what the client got, and how many calls it took.
std::pair<std::string, int> send_all(const LoopListener& listener, const std::string& head,
                                     const std::shared_ptr<const SharedBody>& body) {
  Pair pair;
  const rsd::api::ConnectionOptions options;
  Connection c(pair.daemon, listener, options, Clock::now(), false);
  auto& o = c.http.out();
  o.out = head;
  o.file = body;
  o.file_left = body->bytes().size();
  std::string got;
  int calls = 0;
  while (o.pending() > 0 && calls < 100000) {
    EXPECT_TRUE(rsd::api::send_pending(c));
    ++calls;
    got += pair.read_available();
  }
  got += pair.read_available();
  EXPECT_EQ(o.pending(), 0u);
  EXPECT_FALSE(o.file);  // let go once all of it is out
  return {got, calls};
}

}  // namespace

TEST(SharedBody, SmallBodiesAreCopiedLargeOnesSealedInAMemfd) {
  EXPECT_LT(SharedBody("{\"devices\":[]}\n").fd(), 0);
  const std::string text = body_pattern(100 * 1024);
  SharedBody body(text);
  ASSERT_GE(body.fd(), 0);
  EXPECT_EQ(body.bytes(), text);
  // Sealed: what a client is being sent can no longer change under it.
  const int seals = ::fcntl(body.fd(), F_GET_SEALS);
  EXPECT_TRUE(seals & F_SEAL_WRITE);
  EXPECT_TRUE(seals & F_SEAL_SHRINK);
  EXPECT_LT(::write(body.fd(), "x", 1), 0);
  std::string back(text.size(), '\0');
  EXPECT_EQ(::pread(body.fd(), back.data(), back.size(), 0), static_cast<ssize_t>(text.size()));
  EXPECT_EQ(back, text);
}

// A list that fits in a pipe is held in one too, and each response takes its pages
// by reference (tee): the pipe is never read from, so every response gets it whole.
TEST(SharedBody, ABodyThatFitsAPipeGoesOutWholeToEveryResponse) {
  const auto body = std::make_shared<const SharedBody>(body_pattern(51 * 1024));
  ASSERT_GE(body->pipe(), 0);
  EXPECT_LT(SharedBody(body_pattern(2 * 1024 * 1024)).pipe(), 0);  // beyond a pipe: the memfd alone
  const std::string head = "HTTP/1.1 200 OK\r\nContent-Length: 52224\r\n\r\n";
  LoopListener unix_socket;
  for (int response = 0; response < 3; ++response) {
    const auto [got, calls] = send_all(unix_socket, head, body);
    EXPECT_TRUE(got == head + body->bytes()) << "response " << response;
  }
  int queued = -1;
  ASSERT_EQ(::ioctl(body->pipe(), FIONREAD, &queued), 0);
  EXPECT_EQ(queued, static_cast<int>(body->bytes().size())) << "the body's own pipe was read from";
}

TEST(SendPending, AHeadAndItsBodyArriveWholeAndInOrderOnEitherPath) {
  const auto body = std::make_shared<const SharedBody>(body_pattern(300 * 1024));
  const std::string head = "HTTP/1.1 200 OK\r\nContent-Length: 307200\r\n\r\n";
  LoopListener unix_socket;  // head and body spliced through this thread's pipe
  LoopListener tcp;          // head with MSG_MORE, then sendfile
  tcp.http = true;
  for (const auto* listener : {&unix_socket, &tcp}) {
    const auto [got, calls] = send_all(*listener, head, body);
    EXPECT_EQ(got.size(), head.size() + body->bytes().size()) << listener->http;
    EXPECT_TRUE(got == head + body->bytes()) << "bytes out of order, http=" << listener->http;
    EXPECT_GT(calls, 1) << "the small buffer should have stopped a call part way";
  }
}

// A client that keeps up leaves its socket room: the turn, not EAGAIN, ends a call,
// so a large body goes out in turns between the loop's other connections.
TEST(SendPending, ALargeBodyGoesOutInTurnsThoughTheSocketHasRoom) {
  const auto body = std::make_shared<const SharedBody>(body_pattern(4 * 1024 * 1024));
  const std::string head = "HTTP/1.1 200 OK\r\nContent-Length: 4194304\r\n\r\n";
  LoopListener unix_socket, tcp;
  tcp.http = true;
  for (const auto* listener : {&unix_socket, &tcp}) {
    Pair pair;
    // Room for far more than a turn (as root, past net.core.wmem_max; the suite runs
    // as root): only the turn can end the first call.
    const int room = 8 * 1024 * 1024;
    if (::setsockopt(pair.daemon, SOL_SOCKET, SO_SNDBUFFORCE, &room, sizeof room) != 0)
      ::setsockopt(pair.daemon, SOL_SOCKET, SO_SNDBUF, &room, sizeof room);
    int got_room = 0;
    socklen_t len = sizeof got_room;
    ::getsockopt(pair.daemon, SOL_SOCKET, SO_SNDBUF, &got_room, &len);
    ASSERT_GE(got_room, 4 * static_cast<int>(rsd::api::kSendTurnBytes))
        << "this test needs a send buffer of some turns: run it as root or raise net.core.wmem_max";
    const rsd::api::ConnectionOptions options;
    Connection c(pair.daemon, *listener, options, Clock::now(), false);
    auto& o = c.http.out();
    o.out = head;
    o.file = body;
    o.file_left = body->bytes().size();
    const auto total = o.pending();
    ASSERT_TRUE(rsd::api::send_pending(c));
    const auto first = total - o.pending();
    EXPECT_GT(first, 0u) << listener->http;
    EXPECT_LE(first, rsd::api::kSendTurnBytes + head.size()) << listener->http;
    ASSERT_TRUE(rsd::api::send_pending(c));  // the client read nothing: the room was there
    EXPECT_GT(total - o.pending(), first) << "the first call ended on a full socket, http=" << listener->http;
    std::string got = pair.read_available();
    while (o.pending() > 0 && rsd::api::send_pending(c)) got += pair.read_available();
    got += pair.read_available();
    EXPECT_TRUE(got == head + body->bytes()) << "bytes lost or out of order, http=" << listener->http;
  }
}

TEST(SendPending, AClientGoneMarksTheConnectionBroken) {
  Pair pair;
  LoopListener listener;
  const rsd::api::ConnectionOptions options;
  Connection c(pair.daemon, listener, options, Clock::now(), false);
  c.http.out().out = body_pattern(64 * 1024);
  ::close(pair.client);
  pair.client = -1;
  EXPECT_FALSE(rsd::api::send_pending(c));
  EXPECT_TRUE(c.http.out().broken);
}

TEST(ServerLoop, AStartThatFailsLeavesNothingRunning) {
  // A listener epoll will not watch (a regular file, as a wrong fd from a service
  // manager would be): start throws, and the loop goes away at once instead of
  // leaving the blocking pool's threads behind (the daemon hung on its way out).
  char path[] = "/tmp/rsd-loop-test-XXXXXX";
  const int fd = ::mkstemp(path);
  ASSERT_GE(fd, 0);
  ::unlink(path);
  {
    rsd::api::ServerLoop loop(rsd::api::LoopOptions{});
    LoopListener bad;
    bad.fd = fd;
    bad.name = "a regular file";
    EXPECT_THROW(loop.start({bad}), std::runtime_error);
    loop.stop(std::chrono::milliseconds(0));  // idempotent on a loop never started
  }
  ::close(fd);
}
