// What a host probe's observations mean: a live kernel's refusal or a fresh ARP
// answer is a host present; failed resolution or a router's word, unreachable; a
// neighbour entry the kernel only remembers says nothing yet.
#include "net/host_judge.hpp"

#include <gtest/gtest.h>
#include <linux/neighbour.h>

#include <cerrno>

using namespace std::chrono_literals;
using rsd::model::HostVerdict;
using rsd::net::judge_host;
using rsd::net::NeighbourSeen;
using rsd::net::ProbeSeen;

TEST(HostJudge, SocketErrorsDecide) {
  EXPECT_EQ(judge_host({100ms, ECONNREFUSED, std::nullopt}), HostVerdict::present);
  for (int e : {EHOSTUNREACH, ENETUNREACH, EHOSTDOWN})
    EXPECT_EQ(judge_host({100ms, e, std::nullopt}), HostVerdict::unreachable) << e;
  EXPECT_EQ(judge_host({100ms, 0, std::nullopt}), std::nullopt);  // off-link, no answer yet
}

TEST(HostJudge, OnlyAConfirmationSinceTheProbeBeganMeansPresent) {
  EXPECT_EQ(judge_host({2000ms, 0, NeighbourSeen{NUD_REACHABLE, 500ms}}), HostVerdict::present);
  EXPECT_EQ(judge_host({2000ms, 0, NeighbourSeen{NUD_REACHABLE, 20000ms}}), std::nullopt);  // memory only
  EXPECT_EQ(judge_host({2000ms, 0, NeighbourSeen{NUD_STALE, 30000ms}}), std::nullopt);
  EXPECT_EQ(judge_host({2000ms, 0, NeighbourSeen{NUD_INCOMPLETE, 30000ms}}), std::nullopt);  // resolving
  EXPECT_EQ(judge_host({5000ms, 0, NeighbourSeen{NUD_FAILED, 30000ms}}), HostVerdict::unreachable);
  // The host's own refusal outweighs the kernel's memory of its neighbour.
  EXPECT_EQ(judge_host({100ms, ECONNREFUSED, NeighbourSeen{NUD_FAILED, 30000ms}}), HostVerdict::present);
}
