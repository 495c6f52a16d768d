// LostServers decides when a domain's DDS participant is made anew to find a
// server lost without 'stopping'. Driven here with made-up times, as chrony's
// unit tests drive its source state machine: no DDS, no clock, no sleeping.
#include "dds/lost_servers.hpp"

#include <gtest/gtest.h>

using namespace std::chrono_literals;
using rsd::dds::LostServers;

namespace {

const std::string kServer = "010f3579.d422125f.00000000.000001c1";
const std::string kOther = "010f7529.2623fd62.00000000.000001c1";
const LostServers::Clock::time_point t0{};

// The times of the refreshes `lost` asks for between t0 and `until`, polled
// every 100 ms as the daemon's main loop would.
std::vector<std::chrono::milliseconds> refreshes(LostServers& lost, std::chrono::milliseconds until) {
  std::vector<std::chrono::milliseconds> at;
  for (auto t = 0ms; t <= until; t += 100ms)
    if (lost.check(t0 + t).refresh) at.push_back(t);
  return at;
}

}  // namespace

TEST(LostServers, NoLossNeverRefreshes) {
  LostServers lost;
  lost.participant_alive(kServer);
  EXPECT_TRUE(refreshes(lost, 60min).empty());
  EXPECT_EQ(lost.size(), 0u);
}

TEST(LostServers, AServerThatOnlyDroppedADeviceIsNotLost) {
  LostServers lost;
  lost.participant_alive(kServer);
  lost.writer_lost(kServer, t0);  // its participant is still there
  EXPECT_TRUE(refreshes(lost, 10min).empty());
  EXPECT_FALSE(lost.lost(kServer));
}

TEST(LostServers, WritersFirstThenTheParticipantIsALoss) {
  // On a lease expiry Cyclone drops the writers and the participant in either
  // order: the verdict waits for check_delay.
  LostServers lost;
  lost.participant_alive(kServer);
  lost.writer_lost(kServer, t0);
  EXPECT_FALSE(lost.check(t0 + 100ms).refresh);
  lost.participant_gone(kServer);
  const auto verdict = lost.check(t0 + 500ms);
  EXPECT_EQ(verdict.newly_lost, std::vector<std::string>{kServer});
  EXPECT_TRUE(verdict.refresh);  // 0.5 s after the loss
  EXPECT_EQ(lost.size(), 1u);
}

TEST(LostServers, RefreshesBackOffUntilTheServerIsFound) {
  LostServers lost;
  lost.writer_lost(kServer, t0);  // never seen alive: gone already
  const auto at = refreshes(lost, 15min);
  // 0.5 s after the loss, then 2, 8, 32, 128, 512 s later, then every 10 min.
  const std::vector<std::chrono::milliseconds> expected{500ms,    2500ms,    10500ms,  42500ms,
                                                         170500ms, 682500ms};
  ASSERT_GE(at.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_EQ(at[i], expected[i]) << i;
  EXPECT_EQ(at.size(), expected.size());  // the next would be at 1282.5 s

  lost.announced(kServer);  // its device-info arrived again: found
  EXPECT_EQ(lost.size(), 0u);
  EXPECT_FALSE(lost.check(t0 + 60min).refresh);
}

TEST(LostServers, GivenUpAfterForgetAfter) {
  LostServers lost;
  lost.writer_lost(kServer, t0);
  refreshes(lost, 29min);
  EXPECT_EQ(lost.size(), 1u);
  const auto verdict = lost.check(t0 + 30min);
  EXPECT_EQ(verdict.given_up, std::vector<std::string>{kServer});
  EXPECT_EQ(lost.size(), 0u);
}

TEST(LostServers, OneRefreshServesEveryLostServer) {
  LostServers lost;
  lost.writer_lost(kServer, t0);
  lost.writer_lost(kOther, t0 + 100ms);
  const auto at = refreshes(lost, 3s);
  // kServer is due at 0.5 s, kOther at 0.6 s: the refresh at 0.5 s served both.
  EXPECT_EQ(at, (std::vector<std::chrono::milliseconds>{500ms, 2500ms}));
  EXPECT_EQ(lost.size(), 2u);
}

TEST(LostServers, ARebuiltParticipantForgetsWhatItHeardButNotTheLost) {
  LostServers lost;
  lost.writer_lost(kServer, t0);
  EXPECT_TRUE(lost.check(t0 + 500ms).refresh);
  lost.participant_alive(kOther);
  lost.writer_lost(kOther, t0 + 500ms);  // a suspect at the moment of the rebuild
  lost.participant_rebuilt();
  EXPECT_TRUE(lost.lost(kServer));
  EXPECT_FALSE(lost.check(t0 + 1500ms).refresh);
  EXPECT_FALSE(lost.lost(kOther));  // its suspicion went with the old participant
}
