// One DDS domain's side of the daemon: a Cyclone domain and participant, the
// reader on realsense/device-info, and what it learned about the writers. Feeds
// the table; can be torn down and rebuilt while the table keeps the devices.
#pragma once

#include "dds/domain_book.hpp"
#include "dds/description_fetcher.hpp"
#include "dds/domain_status.hpp"
#include "dds/host_checks.hpp"
#include "dds/share_session.hpp"
#include "net/interfaces.hpp"
#include "table/shared_table.hpp"

#include <dds/dds.h>

#include <chrono>
#include <functional>
#include <mutex>
#include <optional>
#include <set>
#include <string>

namespace rsd::dds {

inline constexpr const char* kDeviceInfoTopic = "realsense/device-info";

struct SessionOptions {
  int domain = 0;
  std::string participant_name = "rs-discoveryd";
  // Cyclone DDS configuration (XML fragment or file://URI); empty: Cyclone's own
  // defaults and CYCLONEDDS_URI.
  std::string cyclone_config;
  // The host's interfaces the domain is joined on (NetworkWatch chooses them and
  // follows the host's changes). Empty: Cyclone DDS chooses. Not used when the user's Cyclone configuration names its
  // own interfaces (`interfaces_from_cyclone_config`): an explicit choice wins.
  std::vector<net::NetInterface> interfaces;
  bool interfaces_from_cyclone_config = false;
  // realdds servers re-announce every 1.5 s; a reader created before Cyclone
  // knows a server's writer loses that server's broadcast for good, so the
  // reader waits this long after the participant is made.
  std::chrono::milliseconds settle{1700};
  // After a refresh for lost servers, the reader waits for their device-info
  // writers up to this long: on a lossy link their endpoints may take seconds to
  // be heard, and a reader made before them misses their broadcast.
  std::chrono::milliseconds settle_for_lost{4000};
  // The domain's bookkeeping: silent writers, caps, reconciliation, lost
  // servers (see DomainBook); its `domain` is set from the one above.
  BookOptions book;
  // The reader's history (the topic has no key, so all writers share one
  // instance): deep enough for a server announcing max_devices_per_participant at
  // once, bounded so a flood is dropped by Cyclone instead of queued without end.
  int reader_history = 1024;
  // Camera Discovery: one fetch of a device's description may take this long
  // (the use case's limit).
  std::chrono::milliseconds describe_timeout{30000};
  // Describe every device of the domain as it appears, not only when asked:
  // for every domain, or for those listed (DomainSet sets `describe_eagerly`
  // per session from the list).
  bool describe_eagerly = false;
  std::set<int> describe_eagerly_in;
  // realdds servers broadcast to a reader as soon as it matches, which takes a
  // few ms once discovery has settled: this long after the first reader exists,
  // the domain's first discovery counts as complete (DomainStatus::complete).
  std::chrono::milliseconds initial_grace{1000};
  // Called from DDS's threads when the session may have a new timer (a writer
  // matched or left, a participant came or went, a description arrived, an
  // announcement to describe eagerly): the main loop then ticks it, so it may
  // sleep until the deadlines tick() returned. Must only wake, never call back in.
  std::function<void()> wake;
  // USB cameras shared between daemons: every session reads other
  // hosts' cameras; with share.share on it also announces this host's.
  ShareOptions share;
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
  void forget_devices(model::RemovalReason reason);
  // DomainBook::set_device_caps (a reload). The reader keeps the history depth
  // it was made with (at least reader_history) until it is made anew.
  void set_device_caps(std::size_t per_participant, std::size_t per_domain);
  // The host's network changed: the participant is made anew on `chosen` (a
  // rebuild, so devices of servers still reachable stay without an event).
  void follow_network(std::vector<net::NetInterface> chosen);

  // Timers: reader creation, and what the book asks for (a new reader, a
  // refresh), shared cameras not heard again, descriptions. The main loop calls
  // it; returns how soon it has something to do (at the latest kIdle), unless
  // `wake` is called first.
  Clock::duration tick(Clock::time_point now);
  static constexpr Clock::duration kIdle = std::chrono::hours(1);

  // The description of this domain's device with `topic_root` (Camera
  // Discovery), fetched from its server on demand; blocks up to `wait`. Any
  // thread. nullopt: no such device on this domain.
  std::optional<DescribeResult> describe(const std::string& topic_root, std::chrono::milliseconds wait);

  bool reading() const;  // the device-info reader exists (initial discovery done)
  int domain() const { return options_.domain; }
  DomainStatus status() const;
  bool discovery_complete() const;  // status().complete, without the rest
  // Every participant heard on the domain but the daemon's own. Any thread.
  std::vector<model::Participant> participants() const;
  // The clients of this domain's device with `topic_root`; nothing when there is no
  // such device. Any thread.
  std::optional<model::DeviceClients> clients(const std::string& topic_root) const;
  // This host's USB cameras now (sighting id -> document), announced on the domain
  // when sharing is on, and again each time the participant is made anew (kept
  // for that: the main loop passes them only when they change). Main thread.
  void share_usb(std::map<std::string, nlohmann::json> cameras);

 private:
  bool complete_locked() const;
  void wake() const {
    if (options_.wake) options_.wake();
  }
  static void on_data_available(dds_entity_t reader, void* arg);
  static void on_participant_data(dds_entity_t reader, void* arg);
  static void on_publication_data(dds_entity_t reader, void* arg);
  static void on_subscription_data(dds_entity_t reader, void* arg);
  static void on_ros_discovery_data(dds_entity_t reader, void* arg);
  static void on_subscription_matched(dds_entity_t reader, dds_subscription_matched_status_t status,
                                      void* arg);
  void take_participant_changes(dds_entity_t reader);
  void take_endpoint_changes(dds_entity_t reader, bool readers);  // readers: DCPSSubscription's
  void take_ros_discovery(dds_entity_t reader);
  void take_samples(dds_entity_t reader);
  void handle_matched(dds_entity_t reader, const dds_subscription_matched_status_t& status);
  // Tells the book about `writer` if it does not know it yet (its GUID, its
  // participant's name and addresses, from Cyclone). Needs mutex_ held.
  void identify(dds_entity_t reader, dds_instance_handle_t writer);
  // Every writer the reader has now, however many. Needs no lock.
  MatchedWriters matched_writers(dds_entity_t reader) const;

  void create_builtin_readers();  // domain_participants.cpp
  // The in-use summary of each camera among `roots` into the table, where it changed.
  // Needs mutex_ held.
  void update_in_use(const std::set<std::string>& roots);
  // The same, for the cameras whose topics `topics` may be.
  void update_in_use_of_topics(const std::vector<std::string>& topics);
  // Whether a topic-root is a camera's, for the clients' bookkeeping (under mutex_).
  realdds_topics::KnownRoot known_root() const;
  // Before the reader exists: whether every server it waits for has its
  // device-info writer known to the participant (takes mutex_).
  bool servers_heard() const;
  // Counts nothing itself (the book does); logs at a limited rate. Needs mutex_ held.
  void refuse_endpoint(EndpointRefusal r, const std::string& participant, std::size_t topic_length);
  void create_reader();
  void delete_reader();

  SessionOptions options_;

  // DDS entities: made and deleted on the main thread only, never under mutex_
  // (deleting a reader waits for its listener, which takes mutex_).
  dds_entity_t domain_ = 0;
  dds_entity_t participant_ = 0;
  dds_entity_t topic_ = 0;
  dds_entity_t reader_ = 0;
  dds_entity_t participant_reader_ = 0;
  Clock::time_point joined_at_{};
  bool rebuilding_ = false;  // start() is making the participant anew (main thread only)

  mutable std::mutex mutex_;  // everything below; listener threads and the main loop
  DomainState state_ = DomainState::stopped;
  std::string error_;
  std::string participant_guid_;
  DomainBook book_;
  ParticipantBook participants_;
  DescriptionFetcher fetcher_;  // its own lock: never taken while holding mutex_
  ShareSession share_;          // its own lock: never taken while holding mutex_
  std::map<std::string, nlohmann::json> usb_cameras_;  // what share_usb() was last given
  HostChecks host_checks_;      // main thread only
  std::optional<Clock::time_point> first_reader_at_;  // kept across rebuilds
  std::uint64_t rebuilds_ = 0, refreshes_ = 0;
  std::uint64_t network_changes_ = 0;
  std::string network_changed_at_;  // when it last followed a change ("" never)
};

// "0110a3b1.22c44e8f.7f000001.000001c1": prefix and entity id, as Cyclone's own
// traces print a GUID.
std::string guid_to_string(const dds_guid_t& guid);

}  // namespace rsd::dds
