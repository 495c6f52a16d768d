// Which realdds servers a domain lost without a 'stopping', and when its DDS
// participant should be made anew to find them again. Pure bookkeeping: no DDS,
// no clock of its own, so unit tests drive it with made-up times.
#pragma once

#include <chrono>
#include <cstddef>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace rsd::dds {

struct LostServerTimes {
  // A refresh comes when the lost server's participant is heard again but none
  // of its devices follows within `rematch_grace` of the reader (measured: after
  // a 3-8 s cut the same Cyclone participant hears the server's participant
  // again, yet never its writers: the server believes it told them already).
  // No grace by default: waiting for a rematch that does not come only delayed
  // the camera, and the new participant's discovery, on a lossy link, takes the
  // longest part of its return.
  // A crashed server is never heard again under its GUID, so it costs nothing:
  // a blind refresh every few seconds slowed the removal of the next crashed
  // server (it cannot unmatch a reader it never matched). Blind ones only
  // in case a server is never heard: `refresh_first` after the loss, then 4x
  // `refresh_again` later each time, up to `refresh_max`. A server lost longer
  // than `forget_after` is given up (a crashed one comes back under another GUID).
  std::chrono::milliseconds refresh_first{30000};
  std::chrono::milliseconds rematch_grace{0};
  // Only the participant that lost the server keeps that stale state: a fresh one
  // that hears it is left to match its writers, however long a lossy link makes
  // that take, and is refreshed again only if it loses the server too (its lease
  // ran out there as well). So no back-off is needed against a peer that never
  // rematches, and a camera heard again on a lossy link is never kept waiting
  // for one: at most one refresh per loss, each rematch_grace after the hearing.
  std::chrono::milliseconds refresh_again{std::chrono::seconds(120)};
  std::chrono::milliseconds refresh_max{std::chrono::minutes(10)};
  std::chrono::milliseconds forget_after{std::chrono::minutes(30)};
  // Writers and their participant leave in either order on a lease expiry: a
  // server is judged lost this long after its devices' writers went.
  std::chrono::milliseconds check_delay{500};
};

class LostServers {
 public:
  using Clock = std::chrono::steady_clock;

  explicit LostServers(LostServerTimes times = {}) : times_(times) {}

  // Cyclone's view of the domain's participants (by GUID).
  void participant_alive(const std::string& guid, Clock::time_point now);
  // Gone (left, or its lease expired) at `now`: remembered for check_delay, as
  // it may be heard again before the verdict (seen under heavy UDP loss: back at
  // once, its writers never matched again by the same participant).
  void participant_gone(const std::string& guid, Clock::time_point now);
  // A fresh DDS participant hears every peer anew; what it heard is forgotten.
  // Servers already lost stay lost.
  void participant_rebuilt();
  // The device-info reader exists from `now` (a lost server heard again has
  // until rematch_grace after both to announce its devices).
  void reader_made(Clock::time_point now) { reading_since_ = now; }

  // A device of `participant` left because its writer did (not by 'stopping').
  void writer_lost(const std::string& participant, Clock::time_point now);
  // `participant` announced a device: if it was lost, it is found.
  void announced(const std::string& participant) { lost_.erase(participant); }

  struct Verdict {
    bool refresh = false;                 // make the participant anew now
    std::vector<std::string> newly_lost;  // for the log
    std::vector<std::string> given_up;
  };
  // Settles the suspects (lost if their participant is gone by now), gives up
  // those lost too long ago, and says whether a refresh is due now; if so, it is
  // counted as done and the next one is scheduled.
  Verdict check(Clock::time_point now);
  // When check() next has something to settle after `now`; nothing while no
  // server is suspect or lost.
  std::optional<Clock::time_point> next_check(Clock::time_point now) const;

  std::size_t size() const { return lost_.size(); }
  std::vector<std::string> participants() const;  // the lost servers' GUIDs
  bool lost(const std::string& participant) const { return lost_.count(participant) > 0; }

 private:
  struct Lost {
    Clock::time_point lost_at;
    Clock::time_point next_refresh;  // blind
    int refreshes = 0;               // blind ones
    std::optional<Clock::time_point> heard_at;  // its participant is alive again
    bool lost_here = true;  // by the current participant, which keeps stale state for it
  };

  LostServerTimes times_;
  std::set<std::string> alive_;                         // participants Cyclone sees now
  std::map<std::string, Clock::time_point> suspects_;   // participant -> when its writers went
  std::map<std::string, Clock::time_point> gone_at_;    // participant -> when it last went
  std::map<std::string, Lost> lost_;                    // by participant GUID
  std::optional<Clock::time_point> last_refresh_;
  std::optional<Clock::time_point> reading_since_;  // the current participant's reader
};

}  // namespace rsd::dds
