// The DDS domains the daemon has joined: one DomainSession each. Start-up joins
// the configured ones; a reload joins new ones and leaves removed ones while the
// unchanged ones (and their devices) carry on untouched.
#pragma once

#include "dds/domain_session.hpp"
#include "dds/domain_status.hpp"
#include "service/wake_fd.hpp"
#include "table/shared_table.hpp"

#include <chrono>
#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace rsd::service {

class DomainSet {
 public:
  using Clock = std::chrono::steady_clock;

  // `base` is the template for every session (participant name, Cyclone config,
  // timings); its `domain` is replaced per session.
  DomainSet(SharedTable& table, dds::SessionOptions base);
  ~DomainSet();
  DomainSet(const DomainSet&) = delete;
  DomainSet& operator=(const DomainSet&) = delete;

  // Start-up: joins every domain; throws std::runtime_error on the first that
  // cannot be joined (the caller exits).
  void start(const std::vector<int>& domains);

  struct Change {
    std::vector<int> joined, left;
    std::vector<std::string> failed;  // "domain 7: why", for domains that could not be joined
  };
  // Reload: joins the listed domains not joined yet, leaves the joined ones not
  // listed (their devices leave the table with them). A domain that cannot be
  // joined is reported in `failed` and left out; the others go on.
  Change apply(const std::vector<int>& domains);

  void rebuild();  // every session's participant made anew (SIGUSR1)
  // The host's network changed: every domain joined anew on `chosen` (and domains
  // joined later too).
  void follow_network(const std::vector<net::NetInterface>& chosen);
  void stop();     // leaves every domain; the table keeps what it has

  // The sessions' timers; returns how soon it wants to be called again. fd() is
  // readable when a session's DDS thread asks for a tick sooner (woken(): whether
  // it did since the last call).
  Clock::duration tick(Clock::time_point now);
  int fd() const { return wake_.fd(); }
  bool woken() { return wake_.take(); }
  // This host's USB cameras now, announced on every domain when share-usb is on
  // (each session writes only what changed), and on domains joined later. Main
  // thread, each time they change.
  void share_usb(const std::map<std::string, nlohmann::json>& cameras);
  // New device caps for every domain, joined now or later (a reload).
  void set_device_caps(std::size_t per_participant, std::size_t per_domain);

  // Main thread only (the one that changes the set).
  std::vector<int> ids() const;
  bool all_reading() const;  // every domain's reader exists (initial discovery done)

  // Any thread (API workers).
  std::vector<DomainStatus> status() const;
  // Every domain's first discovery is over. Lock-free once it is (until the set of
  // domains changes): the API asks it for every device list.
  bool discovery_complete() const;
  // Every domain's participants, by domain.
  std::vector<model::Participant> participants() const;

  // Camera Discovery for the device `id` (an entry of the table, or a sighting
  // merged into one): its description from its realdds server, waiting up to
  // `wait`. Any thread; blocks. See dds::DomainSession::describe.
  DeviceDescription describe(const std::string& id, std::chrono::milliseconds wait) const;
  // Who uses the camera `topic_root` of `domain`. Any thread.
  std::optional<model::DeviceClients> clients(int domain, const std::string& topic_root) const;

 private:
  std::shared_ptr<dds::DomainSession> make(int domain) const;

  std::map<std::string, nlohmann::json> usb_cameras_;  // what share_usb() was last given
  SharedTable& table_;
  WakeFd wake_;  // before base_: the sessions' wake() writes to it
  dds::SessionOptions base_;
  // Only the main thread inserts or erases; it takes the mutex to do so, and
  // other threads take it to read. The main thread reads without it.
  mutable std::mutex mutex_;
  // Shared: an API worker describing a device holds its session while it waits,
  // so a reload that leaves the domain meanwhile cannot pull it from under it.
  std::map<int, std::shared_ptr<dds::DomainSession>> sessions_;
  // Completeness only goes from false to true for a given set of domains: the set's
  // version, bumped with every change to it, and the version last seen complete.
  std::atomic<std::uint64_t> set_version_{1};
  mutable std::atomic<std::uint64_t> complete_version_{0};
};

}  // namespace rsd::service
