// One DDS domain's side of the daemon: a Cyclone domain and participant, the
// reader on realsense/device-info, and what it learned about the writers. Feeds
// the table; can be torn down and rebuilt while the table keeps the devices.
#pragma once

#include "dds/device_info.hpp"
#include "dds/domain_status.hpp"
#include "dds/lost_servers.hpp"
#include "table/shared_table.hpp"

#include <dds/dds.h>

#include <chrono>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace rsd::dds {

inline constexpr const char* kDeviceInfoTopic = "realsense/device-info";

struct SessionOptions {
  int domain = 0;
  std::string participant_name = "rs-discoveryd";
  // Cyclone DDS configuration (XML fragment or file://URI); empty: Cyclone's own
  // defaults and CYCLONEDDS_URI.
  std::string cyclone_config;
  // realdds servers re-announce every 1.5 s; a reader created before Cyclone
  // knows a server's writer loses that server's broadcast for good, so the
  // reader waits this long after the participant is made.
  std::chrono::milliseconds settle{1700};
  // A device writer that matched but sent nothing by then had its broadcast
  // lost all the same (it raced discovery: seen for a server announcing many
  // devices at once on a loaded machine): the reader is made anew, which makes
  // every server broadcast again. Each realdds participant also has one writer
  // on the topic that never writes, so a server counts as silent from two on.
  std::chrono::milliseconds silent_grace{2500};
  int silent_retries = 3;  // per server participant, so a quiet peer can't loop us
  // Caps: a realdds server announces a handful of devices, and one rogue writer
  // could announce thousands (150,000 distinct ones in 2 s, measured). Devices
  // beyond a cap are refused (counted as rejected, logged with a rate limit).
  std::size_t max_devices_per_participant = 128;
  std::size_t max_devices_per_domain = 1024;
  // The reader's history (the topic has no key, so all writers share one
  // instance): deep enough for a server announcing max_devices_per_participant at
  // once, bounded so a flood is dropped by Cyclone instead of queued without end.
  int reader_history = 1024;
  // After the reader or the participant is made anew, a device whose writer has
  // not matched again by then is gone.
  std::chrono::milliseconds reconcile_grace{4000};
  // A server lost without a 'stopping' (its devices left with their writers, and
  // its participant is gone too) may be behind a network cut. After a cut longer
  // than Cyclone's lease of the server but shorter than the server's lease of us,
  // the same Cyclone participant never sees the server's writers again
  // (measured: a 5 s cut, still missing 20 s after the heal); a participant made
  // after the loss finds it like any new peer. So after such a loss the
  // participant is made anew (a refresh), backing off, while the server stays
  // lost (LostServers).
  LostServerTimes lost;
  // realdds servers broadcast to a reader as soon as it matches, which takes a
  // few ms once discovery has settled: this long after the first reader exists,
  // the domain's first discovery counts as complete (DomainStatus::complete).
  std::chrono::milliseconds initial_grace{1000};
};

class DomainSession {
 public:
  using Clock = std::chrono::steady_clock;

  DomainSession(SharedTable& table, SessionOptions options);
  ~DomainSession();
  DomainSession(const DomainSession&) = delete;
  DomainSession& operator=(const DomainSession&) = delete;

  // Joins the domain. Throws std::runtime_error (bad Cyclone config, no usable
  // network interface ...). The reader follows after the settle time, in tick().
  void start();
  // Leaves the domain, DDS entities and all; the table is not touched.
  void stop();
  // stop() + start(), keeping this domain's devices in the table; those whose
  // writers are not found again within reconcile_grace are removed then. The
  // cure for Cyclone's stale discovery state after a short network cut.
  void rebuild();
  // Removes this domain's devices from the table (leaving the domain for good).
  void forget_devices();

  // Timers: reader creation, silent-server retries, reconciliation. The main
  // loop calls it; returns how soon it wants to be called again.
  Clock::duration tick(Clock::time_point now);

  bool reading() const;  // the device-info reader exists (initial discovery done)
  int domain() const { return options_.domain; }
  DomainStatus status() const;

 private:
  struct Writer {
    std::string guid;
    std::string participant_guid;
    Clock::time_point matched_at;
    bool sent = false;  // delivered a sample to the current reader
  };
  struct Server {
    std::string name;
    std::vector<std::string> addresses;
    int silent_retries = 0;
  };

  static void on_data_available(dds_entity_t reader, void* arg);
  static void on_participant_data(dds_entity_t reader, void* arg);
  static void on_subscription_matched(dds_entity_t reader, dds_subscription_matched_status_t status,
                                      void* arg);
  void take_participant_changes(dds_entity_t reader);
  void take_samples(dds_entity_t reader);
  void handle_sample(dds_entity_t reader, dds_instance_handle_t publication, std::int32_t format,
                     std::span<const std::uint8_t> data);
  void handle_matched(dds_entity_t reader, const dds_subscription_matched_status_t& status);
  // Looks up (and caches) the writer and its participant; needs mutex_ held.
  Writer* writer_for(dds_entity_t reader, dds_instance_handle_t publication);
  // Removes devices whose writer is no longer matched; needs mutex_ held.
  void drop_devices_without_writer(dds_entity_t reader, const std::string* only_writer);
  void reject(const std::string& reason, const std::string& detail, const std::string& sender);

  void create_reader();
  void delete_reader();
  void begin_reconcile(Clock::time_point now);

  SharedTable& table_;
  SessionOptions options_;

  // DDS entities: made and deleted on the main thread only, never under mutex_
  // (deleting a reader waits for its listener, which takes mutex_).
  dds_entity_t domain_ = 0;
  dds_entity_t participant_ = 0;
  dds_entity_t topic_ = 0;
  dds_entity_t reader_ = 0;
  dds_entity_t participant_reader_ = 0;
  Clock::time_point joined_at_{};

  mutable std::mutex mutex_;  // everything below; listener threads and the main loop
  std::string state_ = "stopped";
  std::string error_;
  std::string participant_guid_;
  std::map<dds_instance_handle_t, Writer> writers_;       // matched to the current reader
  std::map<std::string, Server> servers_;                // by participant GUID
  // A device of this domain in the table, and every writer announcing it: two
  // servers may serve one topic-root, and the device stays while either does.
  struct Announced {
    nlohmann::json doc;  // as last given to the table
    // writer GUID -> that writer's "server" object; `shown` is the one in `doc`
    // (the latest announcer still there).
    std::vector<std::pair<std::string, nlohmann::json>> announcers;
  };
  std::map<std::string, Announced> devices_;              // by device id
  std::map<std::string, std::size_t> devices_per_participant_;  // announced, by participant GUID
  void add_announcer(Announced& device, const std::string& writer_guid, nlohmann::json server);
  // Drops one announcer of `id`; the device leaves the table with its last one,
  // else shows the latest remaining announcer. Returns whether it left.
  bool drop_announcer(const std::string& id, const std::string& writer_guid, const std::string& why);
  std::optional<Clock::time_point> reconcile_at_;
  std::optional<Clock::time_point> first_reader_at_;  // kept across rebuilds
  LostServers lost_servers_;
  std::uint64_t accepted_ = 0, stopping_ = 0, rebuilds_ = 0, refreshes_ = 0;
  std::map<std::string, std::uint64_t> rejected_;
};

// "0110a3b1.22c44e8f.7f000001.000001c1": prefix and entity id, as Cyclone's own
// traces print a GUID.
std::string guid_to_string(const dds_guid_t& guid);

}  // namespace rsd::dds
