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
  // The first refresh comes this long after a loss; each next one 4x later, up
  // to `refresh_max`; a server lost longer than `forget_after` is given up.
  std::chrono::milliseconds refresh_first{500};
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
  void participant_alive(const std::string& guid) { alive_.insert(guid); }
  void participant_gone(const std::string& guid) { alive_.erase(guid); }
  // A fresh DDS participant hears every peer anew; what it heard is forgotten.
  // Servers already lost stay lost.
  void participant_rebuilt();

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

  std::size_t size() const { return lost_.size(); }
  bool lost(const std::string& participant) const { return lost_.count(participant) > 0; }

 private:
  struct Lost {
    Clock::time_point lost_at;
    Clock::time_point next_refresh;
    int refreshes = 0;
  };

  LostServerTimes times_;
  std::set<std::string> alive_;                         // participants Cyclone sees now
  std::map<std::string, Clock::time_point> suspects_;   // participant -> when its writers went
  std::map<std::string, Lost> lost_;                    // by participant GUID
  std::optional<Clock::time_point> last_refresh_;
};

}  // namespace rsd::dds
