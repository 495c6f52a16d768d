// HttpConnection, the API connection's decisions, driven through each state on a
// made-up clock with a stubbed socket and httplib (http_connection_driver.hpp), as
// DomainBook's tests drive it: a request a byte at a time, pipelining, limits,
// every deadline, the stop in each state, and an SSE stream's back-pressure.
#include "http_connection_driver.hpp"

#include <gtest/gtest.h>

namespace {

using namespace rsd::api::test;
using rsd::api::kFirstRequestWait;
using rsd::api::kStreamStall;
using Interest = rsd::api::HttpConnection::Interest;

TEST(HttpConnection, ARequestAByteAtATimeIsServedOnceItIsAllThere) {
  Driver d;
  d.open();
  const std::string request = get("/v1/devices");
  for (std::size_t i = 0; i + 1 < request.size(); ++i) {
    d.feed(request.substr(i, 1));
    ASSERT_TRUE(d.served.empty()) << "served after " << i + 1 << " bytes";
    ASSERT_EQ(d.interest, Interest::read);
  }
  d.feed(request.substr(request.size() - 1));
  ASSERT_EQ(d.served, std::vector<std::string>{"/v1/devices"});
  const auto r = d.responses();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].body, "/v1/devices");
  EXPECT_EQ(d.m->state(), State::reading);  // kept alive for the next one
  EXPECT_FALSE(d.closed);
}

TEST(HttpConnection, TwoPipelinedRequestsAreAnsweredInOrderOneAtATime) {
  Driver d;
  d.open();
  d.room = 7;  // the socket takes a little at a time: the first answer is still going out
  d.feed(get("/a") + get("/b"));
  // The second waits until the first answer is all out: responses never interleave.
  EXPECT_EQ(d.served, std::vector<std::string>{"/a"});
  EXPECT_EQ(d.m->state(), State::writing);
  EXPECT_EQ(d.interest, Interest::write);
  for (int i = 0; i < 100 && d.served.size() < 2; ++i) d.writable();
  for (int i = 0; i < 1000 && d.m->out().pending() > 0; ++i) d.writable();
  EXPECT_EQ(d.served, (std::vector<std::string>{"/a", "/b"}));
  const auto r = d.responses();
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].body, "/a");
  EXPECT_EQ(r[1].body, "/b");
  EXPECT_EQ(d.m->state(), State::reading);
}

TEST(HttpConnection, AHeadOverTheLimitIsRefusedWith431AndClosed) {
  Driver d;
  d.open();
  d.feed("GET / HTTP/1.1\r\nX-Big: " + std::string(2000, 'a'));  // no end of head yet, past 1024
  const auto r = d.responses();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].status, 431);
  EXPECT_TRUE(r[0].close);
  EXPECT_TRUE(d.closed);
  EXPECT_TRUE(d.served.empty());
  EXPECT_EQ(d.counts.rejected, 1u);
}

TEST(HttpConnection, ABodyOverTheLimitIs413AndABadLengthIs400) {
  for (const auto& [extra, status] : {std::pair{std::string("Content-Length: 65\r\n"), 413},
                                      std::pair{std::string("Content-Length: x\r\n"), 400}}) {
    Driver d;
    d.open();
    d.feed(get("/a", extra));
    const auto r = d.responses();
    ASSERT_EQ(r.size(), 1u) << extra;
    EXPECT_EQ(r[0].status, status);
    EXPECT_TRUE(d.closed);
  }
}

TEST(HttpConnection, ASilentClientIsClosedAtTheClientTimeoutWithoutAnAnswer) {
  Driver d;
  d.options.client_timeout = 1000ms;
  d.open();
  d.tick(999ms);
  EXPECT_FALSE(d.closed);
  d.tick(1ms);
  EXPECT_TRUE(d.closed);
  EXPECT_TRUE(d.wire.empty());
  EXPECT_EQ(d.counts.timed_out, 0u);  // nothing was asked: not a timeout
}

TEST(HttpConnection, APartialRequestGets408AtTheClientTimeoutFromItsFirstByte) {
  Driver d;
  d.options.client_timeout = 1000ms;
  d.open();
  d.tick(500ms);
  d.feed("GET /v1/dev");  // the clock for the request starts here
  d.tick(999ms);
  EXPECT_FALSE(d.closed);
  d.feed("ices HTTP/1.1\r\n");  // more bytes do not extend it
  d.tick(1ms);
  const auto r = d.responses();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].status, 408);
  EXPECT_TRUE(d.closed);
  EXPECT_EQ(d.counts.timed_out, 1u);
  EXPECT_TRUE(d.served.empty());
}

TEST(HttpConnection, AnIdleKeepAliveIsClosedAtTheIdleTimeoutNotTheClientTimeout) {
  Driver d;
  d.options.client_timeout = 1000ms;
  d.options.idle_timeout = 5000ms;
  d.open();
  d.feed(get("/a"));
  ASSERT_EQ(d.served.size(), 1u);
  d.tick(1000ms);
  EXPECT_FALSE(d.closed) << "an idle keep-alive has the idle timeout, not the client timeout";
  d.tick(3999ms);
  EXPECT_FALSE(d.closed);
  d.tick(1ms);
  EXPECT_TRUE(d.closed);
  EXPECT_EQ(d.counts.timed_out, 0u);
}

TEST(HttpConnection, AResponseTheClientDoesNotReadTimesOut) {
  Driver d;
  d.options.client_timeout = 1000ms;
  d.open();
  d.room = 0;
  d.feed(get("/a"));
  EXPECT_EQ(d.m->state(), State::writing);
  d.tick(999ms);
  EXPECT_FALSE(d.closed);
  d.tick(1ms);
  EXPECT_TRUE(d.closed);
  EXPECT_EQ(d.counts.timed_out, 1u);
}

TEST(HttpConnection, AParkedRequestKeepsLaterPipelinedOnesWaiting) {
  Driver d;
  d.options.blocking = [](std::string_view target) { return target.rfind("/slow", 0) == 0; };
  d.open();
  d.feed(get("/slow") + get("/fast"));
  EXPECT_TRUE(d.parked);
  EXPECT_EQ(d.parked_target, "/slow");
  EXPECT_EQ(d.m->state(), State::parked);
  EXPECT_EQ(d.interest, Interest::none);  // the loop keeps off the socket meanwhile
  d.feed(get("/later"));
  d.tick(100ms);
  EXPECT_TRUE(d.served.empty()) << "a request behind a parked one was served first";
  EXPECT_TRUE(d.wire.empty());
  d.tick(60000ms);  // deadlines do not apply while parked (the pool's wait is bounded)
  EXPECT_FALSE(d.closed);
  d.unpark();
  EXPECT_EQ(d.served, (std::vector<std::string>{"/slow", "/fast", "/later"}));
  const auto r = d.responses();
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r[0].body, "/slow");
  EXPECT_EQ(r[2].body, "/later");
}

TEST(HttpConnection, AFullBlockingPoolAnswers503AndCloses) {
  Driver d;
  d.options.blocking = [](std::string_view) { return true; };
  d.open();
  d.feed(get("/slow") + get("/next"));
  ASSERT_TRUE(d.parked);
  d.parked = false;
  d.m->park_refused(d.now);
  d.run();
  const auto r = d.responses();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].status, 503);
  EXPECT_TRUE(d.closed);
}

TEST(HttpConnection, AnEndOfFileAfterACompleteRequestIsAnsweredThenClosed) {
  Driver d;
  d.open();
  d.m->bytes(get("/a"), d.now);
  d.m->eof();
  d.run();
  ASSERT_EQ(d.responses().size(), 1u);
  EXPECT_TRUE(d.closed);
}

TEST(HttpConnection, StopClosesAnIdleKeepAliveAtOnce) {
  Driver d;
  d.open();
  d.feed(get("/a"));
  ASSERT_FALSE(d.closed);
  const auto before = d.wire;
  d.m->stop(d.now);
  d.run();
  EXPECT_TRUE(d.closed);
  EXPECT_EQ(d.wire, before);
}

TEST(HttpConnection, StopAnswersAFreshConnectionsRequestWithinTheFirstRequestWait) {
  Driver d;
  d.open();
  d.m->stop(d.now);
  d.run();
  EXPECT_FALSE(d.closed) << "a fresh connection's request may be on its way";
  d.tick(kFirstRequestWait - 1ms);
  d.feed(get("/a"));
  const auto r = d.responses();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].body, "/a");
  EXPECT_TRUE(d.closed) << "answered, then closed: the daemon is stopping";
}

TEST(HttpConnection, StopClosesASilentFreshConnectionAtTheFirstRequestWait) {
  Driver d;
  d.open();
  d.m->stop(d.now);
  d.run();
  d.tick(kFirstRequestWait - 1ms);
  EXPECT_FALSE(d.closed);
  d.tick(1ms);
  EXPECT_TRUE(d.closed);
  EXPECT_TRUE(d.wire.empty());
}

TEST(HttpConnection, StopAnswersARequestAlreadyInAndOneWaitingBehindAResponse) {
  Driver d;
  d.open();
  d.m->bytes(get("/a"), d.now);  // read, not yet acted on when the stop comes
  d.m->stop(d.now);
  d.run();
  auto r = d.responses();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_TRUE(d.closed);

  Driver w;  // a response still going out when the stop comes: finished, then closed
  w.open();
  w.room = 3;
  w.feed(get("/b"));
  ASSERT_EQ(w.m->state(), State::writing);
  w.m->stop(w.now);
  w.room = 1 << 20;
  w.writable();
  r = w.responses();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].body, "/b");
  EXPECT_TRUE(w.closed);
}

TEST(HttpConnection, StopAnswersAParkedRequestThenCloses) {
  Driver d;
  d.options.blocking = [](std::string_view) { return true; };
  d.open();
  d.feed(get("/slow"));
  d.m->stop(d.now);
  d.run();
  EXPECT_FALSE(d.closed);
  d.unpark();
  ASSERT_EQ(d.responses().size(), 1u);
  EXPECT_TRUE(d.closed);
}

TEST(HttpConnection, StopEndsAStreamWithItsLastChunk) {
  Driver d;
  d.open();
  d.feed(get("/events"));
  ASSERT_EQ(d.m->state(), State::streaming);
  d.m->stream_text("data: 1\n\n", d.now);
  d.run();
  EXPECT_NE(d.wire.find(rsd::api::chunk("data: 1\n\n")), std::string::npos);
  d.m->stop(d.now);
  d.run();
  EXPECT_TRUE(d.closed);
  ASSERT_GE(d.wire.size(), 5u);
  EXPECT_EQ(d.wire.substr(d.wire.size() - 5), "0\r\n\r\n");
}

TEST(HttpConnection, AStreamThatStopsReadingIsDroppedAtItsBufferLimit) {
  Driver d;
  d.options.stream_buffer_limit = 1024;
  d.open();
  d.feed(get("/events"));
  ASSERT_EQ(d.m->state(), State::streaming);
  d.room = 0;  // the client reads nothing more
  const std::string event = "data: " + std::string(90, 'x') + "\n\n";  // 98 bytes, 104 chunked
  int sent = 0;
  while (!d.closed && sent < 100) {
    d.m->stream_text(event, d.now);
    d.run();
    ++sent;
    if (!d.closed) {
      EXPECT_LE(d.m->out().pending(), 1024u);
      EXPECT_EQ(d.interest, Interest::read_write);
    }
  }
  EXPECT_TRUE(d.closed);
  EXPECT_EQ(sent, 10) << "dropped at the first event past 1024 unread bytes";
  EXPECT_EQ(d.counts.backlog_drops, 1u);
}

TEST(HttpConnection, AStreamWhoseSocketTakesNothingIsDroppedAfterTheStall) {
  Driver d;
  d.open();
  d.feed(get("/events"));
  d.room = 0;
  d.m->stream_text("data: 1\n\n", d.now);
  d.run();
  d.tick(kStreamStall - 1ms);
  EXPECT_FALSE(d.closed);
  d.tick(1ms);
  EXPECT_TRUE(d.closed);
  EXPECT_EQ(d.counts.stall_drops, 1u);

  Driver idle;  // a stream with nothing to send is not stalled, however long
  idle.open();
  idle.feed(get("/events"));
  idle.tick(kStreamStall * 2);
  EXPECT_FALSE(idle.closed);
  idle.m->eof();  // the client went away
  idle.run();
  EXPECT_TRUE(idle.closed);
}

TEST(HttpConnection, HttplibAskingForACloseIsHonouredAfterTheAnswer) {
  Driver d;
  d.open();
  d.feed(get("/close") + get("/b"));
  const auto r = d.responses();
  ASSERT_EQ(r.size(), 1u);
  EXPECT_TRUE(d.closed);
  EXPECT_EQ(d.served.size(), 1u);
}

}  // namespace
