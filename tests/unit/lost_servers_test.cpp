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
  lost.participant_alive(kServer, t0);
  EXPECT_TRUE(refreshes(lost, 60min).empty());
  EXPECT_EQ(lost.size(), 0u);
}

TEST(LostServers, AServerThatOnlyDroppedADeviceIsNotLost) {
  LostServers lost;
  lost.participant_alive(kServer, t0);
  lost.writer_lost(kServer, t0);  // its participant is still there
  EXPECT_TRUE(refreshes(lost, 10min).empty());
  EXPECT_FALSE(lost.lost(kServer));
}

TEST(LostServers, WritersFirstThenTheParticipantIsALoss) {
  // On a lease expiry Cyclone drops the writers and the participant in either
  // order: the verdict waits for check_delay.
  LostServers lost;
  lost.participant_alive(kServer, t0);
  lost.writer_lost(kServer, t0);
  EXPECT_FALSE(lost.check(t0 + 100ms).refresh);
  lost.participant_gone(kServer, t0 + 200ms);
  const auto verdict = lost.check(t0 + 500ms);
  EXPECT_EQ(verdict.newly_lost, std::vector<std::string>{kServer});
  EXPECT_FALSE(verdict.refresh);  // nothing to gain before it is heard again (or 30 s)
  EXPECT_EQ(lost.size(), 1u);
}

TEST(LostServers, GoneAndHeardAgainBeforeTheVerdictIsStillALoss) {
  // 20 % UDP loss: the lease runs out, the participant is heard again 100 ms later,
  // but the same Cyclone participant never matches its writers again. It went: it
  // is lost (and, heard already, refreshed after the grace), not "still alive".
  LostServers lost({.rematch_grace = 500ms});
  lost.reader_made(t0 - 60s);
  lost.participant_alive(kServer, t0 - 10s);
  lost.participant_gone(kServer, t0);
  lost.writer_lost(kServer, t0);
  lost.participant_alive(kServer, t0 + 100ms);
  const auto verdict = lost.check(t0 + 500ms);
  EXPECT_EQ(verdict.newly_lost, std::vector<std::string>{kServer});
  EXPECT_TRUE(lost.lost(kServer));
  EXPECT_FALSE(lost.check(t0 + 900ms).refresh);
  EXPECT_TRUE(lost.check(t0 + 1s).refresh);  // rematch_grace after it was judged lost, heard
  // A device dropped long after the participant last went is no loss.
  LostServers other;
  other.participant_gone(kOther, t0);
  other.participant_alive(kOther, t0 + 1s);
  other.writer_lost(kOther, t0 + 10s);
  EXPECT_TRUE(other.check(t0 + 11s).newly_lost.empty());
  EXPECT_FALSE(other.lost(kOther));
}

TEST(LostServers, BlindRefreshesBackOffUntilTheServerIsFound) {
  LostServers lost;
  lost.writer_lost(kServer, t0);  // never seen alive: gone already, and never heard again
  const auto at = refreshes(lost, 25min);
  // 30 s after the loss, then 120 s later, then 4x later each time up to 10 min.
  const std::vector<std::chrono::milliseconds> expected{30s, 150s, 630s, 1230s};
  EXPECT_EQ(at, expected);

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
  const auto at = refreshes(lost, 31s);
  // kServer is due at 30 s, kOther at 30.1 s: the refresh at 30 s served both.
  EXPECT_EQ(at, (std::vector<std::chrono::milliseconds>{30s}));
  EXPECT_EQ(lost.size(), 2u);
}

TEST(LostServers, ARebuiltParticipantForgetsWhatItHeardButNotTheLost) {
  LostServers lost;
  lost.writer_lost(kServer, t0);
  EXPECT_TRUE(lost.check(t0 + 30s).refresh);
  lost.participant_alive(kOther, t0);
  lost.writer_lost(kOther, t0 + 30s);  // a suspect at the moment of the rebuild
  lost.participant_rebuilt();
  EXPECT_TRUE(lost.lost(kServer));
  EXPECT_FALSE(lost.check(t0 + 31s).refresh);
  EXPECT_FALSE(lost.lost(kOther));  // its suspicion went with the old participant
}

TEST(LostServers, HeardAgainWithoutItsDevicesRefreshesAtOnce) {
  // What a cut of 3-8 s looks like: the server's participant comes back, its
  // writers never match the same Cyclone participant.
  LostServers lost;
  lost.reader_made(t0 - 60s);
  lost.writer_lost(kServer, t0);
  EXPECT_FALSE(lost.check(t0 + 500ms).refresh);
  EXPECT_FALSE(lost.check(t0 + 1900ms).refresh);
  lost.participant_alive(kServer, t0 + 2s);  // the cut healed
  EXPECT_EQ(lost.next_check(t0 + 1900ms), t0 + 2s);
  EXPECT_TRUE(lost.check(t0 + 2s).refresh);  // at once: the participant that lost it never rematches
  // The new participant hears it during the settle time, before its reader. It
  // keeps no stale state: however long its writers take to match (a lossy link),
  // no second refresh comes for them, so a peer that never rematches can't loop us.
  lost.participant_rebuilt();
  lost.participant_alive(kServer, t0 + 3s);
  lost.reader_made(t0 + 4200ms);
  // (Only the blind one, refresh_again after the last, comes: at 122 s.)
  for (auto t = t0 + 3s; t < t0 + 122s; t += 100ms) EXPECT_FALSE(lost.check(t).refresh) << (t - t0).count();
  EXPECT_TRUE(lost.check(t0 + 122s).refresh);
}

TEST(LostServers, EachLossOnALossyLinkIsOneRefreshRematchGraceAfterTheHearing) {
  // 30 % loss: each new participant may lose the server again (its lease runs out
  // there too) and hear it again. Every such loss gets its refresh the grace after
  // the hearing, however many came before: no back-off keeps the camera away.
  LostServers lost({.rematch_grace = 500ms});
  lost.reader_made(t0 - 60s);
  lost.participant_alive(kServer, t0 - 60s);
  lost.participant_gone(kServer, t0);
  lost.writer_lost(kServer, t0);
  lost.check(t0 + 500ms);
  ASSERT_TRUE(lost.lost(kServer));
  auto t = t0 + 1s;
  for (int loss = 0; loss < 12; ++loss) {
    lost.participant_alive(kServer, t);  // heard again by the participant that lost it
    EXPECT_FALSE(lost.check(t + 400ms).refresh) << loss;
    EXPECT_EQ(lost.next_check(t + 400ms), t + 500ms) << loss;
    EXPECT_TRUE(lost.check(t + 500ms).refresh) << loss;
    lost.participant_rebuilt();
    lost.reader_made(t + 1500ms);
    lost.participant_alive(kServer, t + 1s);
    EXPECT_FALSE(lost.check(t + 3s).refresh) << loss;  // a fresh one matching: left alone
    lost.participant_gone(kServer, t + 4s);             // and losing it in turn
    t += 5s;
  }
}

TEST(LostServers, HeardAgainAndAnnouncingIsFound) {
  LostServers lost;
  lost.reader_made(t0 - 60s);
  lost.writer_lost(kServer, t0);
  lost.check(t0 + 500ms);
  lost.participant_alive(kServer, t0 + 5s);
  lost.announced(kServer);  // its device-info came (a long cut heals by itself)
  EXPECT_EQ(lost.size(), 0u);
  for (auto t = 5s; t < 60s; t += 1s) EXPECT_FALSE(lost.check(t0 + t).refresh);
}

// The main loop ticks only at next_check(): following it alone gives the same
// refreshes as polling every 100 ms.
TEST(LostServers, FollowingNextCheckGivesThePolledRefreshes) {
  LostServers polled, followed;
  for (LostServers* l : {&polled, &followed}) {
    l->participant_alive(kServer, t0);
    l->reader_made(t0);
    l->participant_gone(kServer, t0);
    l->writer_lost(kServer, t0);
  }
  const auto expected = refreshes(polled, 40min);
  ASSERT_FALSE(expected.empty());
  std::vector<std::chrono::milliseconds> got;
  for (auto at = followed.next_check(t0); at && *at <= t0 + 40min; at = followed.next_check(*at))
    if (followed.check(*at).refresh) got.push_back(std::chrono::ceil<std::chrono::milliseconds>(*at - t0));
  // Polling sees each refresh at the first 100 ms step at or after its deadline.
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_LE(got[i], expected[i]);
    EXPECT_GT(got[i] + 100ms, expected[i]);
  }
  EXPECT_EQ(followed.next_check(t0 + 40min), std::nullopt);  // given up: nothing left to time
}
