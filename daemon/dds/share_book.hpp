// What one DDS domain knows about the USB cameras other daemons share on it:
// which instances of rs-discoveryd/shared-usb are in the table, under
// which id, for which participant; the caps; what it refused. No DDS in it: the
// share shell (ShareSession) turns Cyclone's samples and instance states into
// these calls under its lock, and unit tests drive the same calls.
#pragma once

#include "dds/shared_usb.hpp"
#include "dds/domain_status.hpp"
#include "table/shared_table.hpp"

#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <variant>

namespace rsd::dds {

struct ShareBookOptions {
  int domain = 0;
  // A host has a handful of USB cameras; a rig PC a few more. Beyond a cap a
  // camera is refused and counted, as device-info is (a sharer, however
  // hostile, cannot grow the table or the daemon without bound).
  std::size_t max_per_participant = 64;
  std::size_t max_per_domain = 1024;
  // After a new reader (the participant made anew) the sharers' transient-local
  // samples arrive again at once; a camera not heard again by then is gone.
  std::chrono::milliseconds reconcile_grace{3000};
  // A camera whose instance lost its writers without being disposed (the sharer's
  // participant made anew after a network change or a lost server, or its lease
  // expired) stays this long for a new writer to take it over: a sharer's refresh
  // is no departure and arrival for every other host.
  std::chrono::milliseconds orphan_grace{2000};
};

class ShareBook {
 public:
  using Clock = std::chrono::steady_clock;
  using Instance = std::uint64_t;  // the reader's instance handle

  ShareBook(SharedTable& table, ShareBookOptions options);

  // The daemon's own participant: its samples never become entries (Cyclone is
  // also told to ignore them; this holds if it does not).
  void set_own_participant(std::string guid) { own_ = std::move(guid); }

  // A sample of `instance` (alive) from a writer of `participant_guid`, parsed.
  void sample(Instance instance, const std::string& participant_guid, std::variant<SharedCamera, Rejected> parsed);
  // The instance was disposed (unplugged, sharer stopped): its camera leaves the
  // table now. Or it has no writer left (sharer made anew, or gone: lease
  // expired): it leaves after orphan_grace unless a writer takes it over.
  void instance_gone(Instance instance, bool disposed, Clock::time_point now);

  // A new reader: instance handles start over. Cameras stay until reconcile_grace
  // passes without their instance being heard again.
  void reader_made(Clock::time_point now);
  // Returns how soon it wants to be called again (reconciliation); kIdle when
  // no shared camera waits to be heard again.
  Clock::duration tick(Clock::time_point now);
  static constexpr Clock::duration kIdle = std::chrono::hours(1);

  // Leaving the domain: every shared camera of it leaves the table.
  void forget_devices(model::RemovalReason reason);

  std::size_t size() const { return instances_.size(); }
  // The rejected counts (shared-*), added to the domain's.
  void fill(DomainStatus& status) const;

 private:
  struct Entry {
    std::string id;
    std::string participant;
    nlohmann::json doc;  // as last given to the table
  };
  void drop(std::map<Instance, Entry>::iterator it, const char* why, model::RemovalReason reason);
  void release(std::map<std::string, std::size_t>::iterator per_participant);
  void reject(const std::string& reason, const std::string& detail, const std::string& sender);

  SharedTable& table_;
  ShareBookOptions options_;
  std::string own_;
  std::map<Instance, Entry> instances_;               // in the table
  std::map<std::string, Instance> by_id_;             // id -> its instance
  std::map<std::string, std::size_t> per_participant_;
  // By id: kept over a new reader or a lost writer until heard again, or until
  // their deadline.
  struct Stale {
    Entry entry;
    Clock::time_point until;
  };
  std::map<std::string, Stale> stale_;
  std::map<std::string, std::uint64_t> rejected_;
};

}  // namespace rsd::dds
