// HttpConnection fed random traffic, as chrony's unit tests feed its sources: a
// run of requests (some parked, some with bodies, now and then garbage) split at
// random points, a socket that takes random amounts, random waits and a stop or
// an end of file at random. Whatever happens, answers come in request order, at
// most one per request, and the connection ends closed or reading. The seed is
// printed; RSD_SEED=<n> replays one.
#include "http_connection_driver.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>
#include <random>

namespace {

using namespace rsd::api::test;

struct Run {
  std::string input;                 // every byte the client sends
  std::vector<std::string> targets;  // the well-formed requests, in order, before any garbage
  bool garbage = false;              // a request the scan refuses follows them
};

Run make_run(std::mt19937_64& rng) {
  Run run;
  const int requests = std::uniform_int_distribution<int>(1, 12)(rng);
  for (int i = 0; i < requests; ++i) {
    if (std::uniform_int_distribution<int>(0, 59)(rng) == 0) {
      // Refused before httplib sees it: a 414, 431 or 400; nothing after it is read.
      switch (std::uniform_int_distribution<int>(0, 2)(rng)) {
        case 0: run.input += "GET /" + std::string(600, 'u'); break;
        case 1: run.input += "GET / HTTP/1.1\r\nX: " + std::string(1100, 'h'); break;
        default: run.input += get("/bad", "Content-Length: -1\r\n"); break;
      }
      run.input += get("/never");
      run.garbage = true;
      return run;
    }
    const bool slow = std::uniform_int_distribution<int>(0, 3)(rng) == 0;
    const std::string target = std::string(slow ? "/slow" : "/r") + std::to_string(i);
    const int body = std::uniform_int_distribution<int>(0, 2)(rng) == 0 ? 10 : 0;
    run.input += get(target, body ? "Content-Length: 10\r\n" : "") + std::string(static_cast<std::size_t>(body), 'b');
    run.targets.push_back(target);
  }
  return run;
}

void check_one(std::uint64_t seed) {
  SCOPED_TRACE("seed " + std::to_string(seed));
  std::mt19937_64 rng(seed);
  auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  const Run run = make_run(rng);
  Driver d;
  d.stream_targets = false;
  d.options.client_timeout = 1000ms;
  d.options.idle_timeout = 3000ms;
  d.options.blocking = [](std::string_view target) { return target.rfind("/slow", 0) == 0; };
  d.open();

  std::size_t fed = 0;
  bool stopped = false, ended = false;
  int after = 0;  // steps since the last byte was sent: a few, then the run ends
  for (int step = 0; step < 10000 && !d.closed && after < 30; ++step) {
    if (fed == run.input.size()) ++after;
    d.room = static_cast<std::size_t>(pick(0, 3) == 0 ? 0 : pick(1, 200));
    switch (pick(0, 9)) {
      case 0: case 1: case 2: case 3:  // the client sends a piece
        if (fed < run.input.size() && d.m->state() != State::parked) {
          const auto n = std::min<std::size_t>(run.input.size() - fed, static_cast<std::size_t>(pick(1, 80)));
          d.feed(run.input.substr(fed, n));
          fed += n;
        }
        break;
      case 4: case 5:
        if (d.interest == rsd::api::HttpConnection::Interest::write) d.writable();
        break;
      case 6:
        if (d.parked) d.unpark();
        break;
      case 7:  // time passes: mostly a little, rarely past a deadline
        d.tick(std::chrono::milliseconds(pick(0, 50) == 0 ? pick(900, 4000) : pick(0, 20)));
        break;
      case 8:
        if (!stopped && pick(0, 30) == 0) {
          stopped = true;
          d.m->stop(d.now);
          d.run();
        }
        break;
      default:
        if (!ended && fed == run.input.size() && pick(0, 5) == 0) {
          ended = true;
          d.m->eof();
          d.run();
        }
        break;
    }
    // Never more than one answer per request, and never ahead of what was asked.
    ASSERT_LE(d.served.size(), run.targets.size() + 1);
    for (std::size_t i = 0; i < d.served.size() && i < run.targets.size(); ++i)
      ASSERT_EQ(d.served[i], run.targets[i]) << "served out of order";
  }
  // Let everything that is in finish: the pool returns, the socket drains.
  d.room = std::numeric_limits<std::size_t>::max();
  for (int i = 0; i < 1000 && !d.closed && (d.parked || d.m->out().pending() > 0); ++i) {
    if (d.parked) d.unpark();
    else d.writable();
  }
  ASSERT_TRUE(d.closed || d.m->state() == State::reading)
      << "ended in state " << static_cast<int>(d.m->state());
  if (!d.closed) {
    EXPECT_EQ(d.m->out().pending(), 0u);
  }

  std::string rest;
  const auto responses = d.responses(&rest);
  ASSERT_LE(responses.size(), run.targets.size() + (run.garbage ? 1 : 0));
  std::size_t ok = 0;
  for (const auto& r : responses) {
    if (r.status == 200) {
      ASSERT_LT(ok, run.targets.size());
      ASSERT_EQ(r.body, run.targets[ok]) << "answered out of order";
      ++ok;
      continue;
    }
    // A refusal (or a 408) is the connection's last word.
    ASSERT_TRUE(r.status == 408 || r.status == 414 || r.status == 431 || r.status == 400) << r.status;
    ASSERT_EQ(&r, &responses.back());
    ASSERT_TRUE(d.closed);
  }
  ASSERT_EQ(ok, std::min(ok, d.served.size()));
  ASSERT_TRUE(d.closed || rest.empty()) << "a response cut short on an open connection";
  // Nothing went wrong and nothing cut it short: every request was answered.
  if (!d.closed && fed == run.input.size() && !run.garbage) {
    EXPECT_EQ(ok, run.targets.size());
  }
  if (run.garbage && fed == run.input.size() && !stopped && !ended) {
    EXPECT_TRUE(d.closed);
  }
}

TEST(HttpConnectionRandom, AnswersInOrderAtMostOnceAndEndsClosedOrReading) {
  std::uint64_t seed = std::random_device{}();
  if (const char* s = std::getenv("RSD_SEED")) seed = std::strtoull(s, nullptr, 10);
  std::cout << "HttpConnectionRandom seed " << seed << " (RSD_SEED to replay)\n";
  RecordProperty("seed", std::to_string(seed));
  for (std::uint64_t i = 0; i < 2000; ++i) {
    check_one(seed + i);
    if (HasFatalFailure()) return;
  }
}

}  // namespace
