// Camera Discovery on demand: a device's description fetched from its realdds
// server by subscribing to <topic-root>/notification, collecting the set, and
// unsubscribing, so the daemon keeps no load on the camera. Concurrent requests
// for one device share one fetch; a result is kept until the device's
// announcement changes (a restarted server may bring other streams).
#pragma once

#include "dds/description.hpp"

#include <dds/dds.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <optional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace rsd::dds {

struct DescribeResult {
  enum class Outcome {
    ok,           // `description` is the device's
    timeout,      // the server sent no whole set in time
    unavailable,  // the domain has no participant now (starting, rebuilding, leaving)
    gone,         // the device left while it was being described
  };
  Outcome outcome = Outcome::unavailable;
  nlohmann::json description;
  std::string error;  // for the user, when not ok
  std::string stage;  // timeout: how far the set got (DescriptionAssembler::stage)
};

// What a fetch tells of a camera's readiness: whether its whole notification set
// came, and how far it got when not.
struct Readiness {
  bool ready = false;
  std::string stage;  // when not ready
};

class DescriptionFetcher {
 public:
  using Clock = std::chrono::steady_clock;

  // `fetch_timeout`: how long one fetch may take before it is given up (the use
  // case's 30 s); a caller may wait less.
  // `readiness` is called, no lock held, with the topic-root of each device whose
  // description became available (from a DDS listener thread), and of each whose
  // set did not complete within librealsense's wait or the fetch's timeout (from
  // tick(), on the main thread).
  DescriptionFetcher(int domain, std::chrono::milliseconds fetch_timeout,
                     std::function<void(const std::string& topic_root, const Readiness&)> readiness = {});
  ~DescriptionFetcher();
  DescriptionFetcher(const DescriptionFetcher&) = delete;
  DescriptionFetcher& operator=(const DescriptionFetcher&) = delete;

  // Main thread: the participant fetches subscribe with; 0 while there is none.
  // Before the participant is deleted, call with 0: fetches in flight end
  // (unavailable) and their readers are deleted first.
  void set_participant(dds_entity_t participant);

  // Any thread (API workers): blocks until the description of `topic_root` is
  // known, `wait` has passed, or the participant goes. `announcement` is the
  // device as announced now: a description fetched for another one is stale.
  DescribeResult describe(const std::string& topic_root, const nlohmann::json& announcement,
                          std::chrono::milliseconds wait);

  // Starts fetching, without waiting, unless the description is kept, a fetch is
  // under way, or one was tried for this very announcement already. A server
  // whose set does not complete is asked again, after kRetryFirst, then twice as
  // long each time up to kRetryMost, until it does or its announcement changes.
  void prefetch(const std::string& topic_root, const nlohmann::json& announcement);
  static constexpr std::chrono::seconds kRetryFirst{5}, kRetryMost{300};
  // librealsense waits this long for a new device's set (realdds'
  // dds_device::wait_until_ready(), called from rsdds-device-factory.cpp without
  // a timeout) and then gives the device up: a set not complete by then is
  // reported not ready, although the fetch goes on until its own timeout.
  static constexpr std::chrono::milliseconds kLibrealsenseReadyWait{5000};

  // Main thread: deletes the readers of finished or expired fetches, ends those
  // of devices that are gone and drops their kept descriptions (`still_there`
  // says which devices are still announced).
  void tick(Clock::time_point now, const std::function<bool(const std::string& topic_root)>& still_there);
  // When tick() is next wanted: while descriptions are in flight or finished,
  // every kInFlightCheck (a device that leaves mid-fetch is told by tick()), and
  // no later than the soonest fetch's deadline; nothing when none is.
  std::optional<Clock::time_point> next_deadline(Clock::time_point now) const;
  static constexpr std::chrono::milliseconds kInFlightCheck{250};

  std::uint64_t fetches_started() const { return started_.load(); }
  std::map<std::string, std::uint64_t> rejected() const;  // malformed notifications, by reason

 private:
  struct Fetch {
    std::string topic_root;
    nlohmann::json announcement;
    DescriptionAssembler assembler;
    Clock::time_point deadline;
    Clock::time_point ready_deadline;  // kLibrealsenseReadyWait after the start
    bool told_not_ready = false;
    dds_entity_t topic = 0, reader = 0;
    bool done = false;  // complete, failed or expired: nothing more to wait for
    DescribeResult result;
    DescriptionFetcher* owner = nullptr;
  };
  struct Kept {
    nlohmann::json announcement;
    nlohmann::json description;
  };
  struct Tried {  // a prefetched announcement
    nlohmann::json announcement;
    std::optional<Clock::time_point> retry_at;  // after a fetch that did not complete
    Clock::duration backoff = kRetryFirst;
  };

  // Starts or joins the fetch of `topic_root`; nullptr when the answer is at hand
  // already (then in `answer`).
  std::shared_ptr<Fetch> begin(const std::string& topic_root, const nlohmann::json& announcement,
                               DescribeResult& answer);
  static void on_data(dds_entity_t reader, void* arg);
  void take(Fetch& fetch, dds_entity_t reader);
  // Makes the fetch's topic and reader; returns false when the participant is gone.
  bool subscribe(Fetch& fetch, dds_entity_t participant);
  void unsubscribe(Fetch& fetch);

  const int domain_;
  const std::chrono::milliseconds fetch_timeout_;
  const std::function<void(const std::string&, const Readiness&)> readiness_;
  std::atomic<dds_entity_t> participant_{0};
  std::atomic<std::uint64_t> started_{0};

  mutable std::mutex mutex_;  // what follows; never held across a DDS create/delete
  std::condition_variable changed_;
  std::map<std::string, std::shared_ptr<Fetch>> fetches_;  // in flight, by topic-root
  std::vector<std::shared_ptr<Fetch>> finished_;           // readers to delete (main thread)
  std::map<std::string, Kept> kept_;                       // by topic-root
  std::map<std::string, Tried> prefetched_;                // by topic-root
  std::map<std::string, std::uint64_t> rejected_;
};

}  // namespace rsd::dds
