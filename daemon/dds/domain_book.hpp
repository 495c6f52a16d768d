// What one DDS domain knows about the writers on realsense/device-info and the
// devices they announce: the bookkeeping behind DomainSession, with no DDS in it.
// DomainSession turns Cyclone's callbacks into the plain calls below (under its
// own lock) and carries out what tick() asks for; unit tests drive the same
// calls with made-up writers and times, as chrony's tests drive its sources.
#pragma once

#include "dds/device_info.hpp"
#include "dds/domain_status.hpp"
#include "dds/lost_servers.hpp"
#include "dds/participant_book.hpp"
#include "rsd_model/device.hpp"
#include "rsd_model/removal.hpp"
#include "table/shared_table.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdint>
#include <initializer_list>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <unordered_set>
#include <utility>
#include <vector>

namespace rsd::dds {

using WriterHandle = std::uint64_t;  // a reader's instance handle of a writer

// The writers a reader has matched, as Cyclone lists them (any number: a site, or
// one hostile host, may have tens of thousands): sorted once, then looked up.
class MatchedWriters {
 public:
  MatchedWriters() = default;
  MatchedWriters(std::initializer_list<WriterHandle> handles) : MatchedWriters(std::vector<WriterHandle>(handles)) {}
  explicit MatchedWriters(std::vector<WriterHandle> handles);  // sorted here, repeats dropped
  bool contains(WriterHandle handle) const;
  std::size_t size() const { return handles_.size(); }

 private:
  std::vector<WriterHandle> handles_;
};

// A device removed because its server's lease ran out: its host is to be probed
// (hung or gone), and the verdict joins the removal of `generation` in the table.
struct LeaseLoss {
  std::string entry_id;
  std::uint64_t generation = 0;
  std::string server;  // its participant's name, for the log
  std::vector<std::string> addresses;
};

struct BookOptions {
  int domain = 0;
  // A device writer that matched but sent nothing by then had its broadcast
  // lost all the same (it raced discovery: seen for a server announcing many
  // devices at once on a loaded machine): the reader is made anew, which makes
  // every server broadcast again. A realdds server may also have a writer on the
  // topic that never writes (pyrealdds 2.59.1, measured: k devices matched k
  // writers in some runs, k + 1 in others). So a server is asked again when it has
  // two silent writers, or one and no device at all (its only broadcast lost); a
  // writer that stays silent for the new reader too is idle and not counted again.
  // A server with devices and one silent writer is left alone: making the reader
  // anew for every such server slowed the noticing of a SIGKILL (bench, measured).
  std::chrono::milliseconds silent_grace{2500};
  // A server the daemon waits for (one it lost, or whose kept devices have not been
  // announced to the current reader: after a refresh, on a lossy link) is asked
  // again sooner, with one silent writer as with several: its broadcast, when it
  // comes, comes within milliseconds of the match, and its camera is listed again
  // only once it does.
  // On a lossy link each new reader's broadcast is a new draw, so one awaited is
  // asked more often and more times.
  std::chrono::milliseconds awaited_silent_grace{600};
  int silent_retries = 3;  // per server participant, so a quiet peer can't loop us (anew after each loss)
  int awaited_silent_retries = 8;
  // Caps: a realdds server announces a handful of devices, and one rogue writer
  // could announce distinct ones faster than any table should keep them. Devices
  // beyond a cap are refused (counted as rejected, logged with a rate limit).
  std::size_t max_devices_per_participant = 128;
  std::size_t max_devices_per_domain = 1024;
  // Writers are not devices: a host can match any number of device-info writers
  // that announce nothing (thousands from one process, measured), and each one
  // tracked costs memory and work per departure. A realdds server has one per
  // device and at most one more; beyond a cap a writer is refused: counted
  // (DomainStatus::writers_refused), logged with a rate limit, its samples
  // dropped, until a new reader (it is not admitted when room frees up: a writer
  // broadcasts on a match, and it matched already).
  std::size_t max_writers_per_participant = 256;
  std::size_t max_writers_per_domain = 2048;
  // After the reader or the participant is made anew, a device whose writer has
  // not matched again by then is gone. Matching a settled participant's writers
  // takes milliseconds; the grace is also how late a server killed during a
  // refresh is noticed (it cannot unmatch a reader it never matched).
  std::chrono::milliseconds reconcile_grace{2000};
  // removal-grace: a device whose server's lease ran out stays listed, marked
  // unresponsive, this long, and is not removed if heard again by then (0: removed
  // at once, as realdds does). A lossy link then does not make a dashboard flicker.
  std::chrono::milliseconds removal_grace{0};
  // A client leaving takes its endpoints away one by one (its stream readers, then
  // its device's, then its participant): an in-use summary losing a client or a
  // stream is held this long, so the camera changes once when the client goes. A
  // client coming, or a stream opened, is written at once.
  std::chrono::milliseconds in_use_hold{50};
  // A device whose server was heard again within its removal grace, but not its
  // device-info yet, is kept this much longer: on a lossy link the fresh participant
  // that finds the server's writers again can take seconds to hear them.
  std::chrono::milliseconds heard_again_grace{10000};
  LostServerTimes lost;
};

// A writer as DDS describes it, with its participant's name and addresses.
struct WriterIdentity {
  std::string guid;
  std::string participant_guid;
  std::string participant_name;
  std::vector<std::string> addresses;
};

class DomainBook {
 public:
  using Clock = std::chrono::steady_clock;
  using Handle = WriterHandle;

  DomainBook(SharedTable& table, BookOptions options);

  // A writer matched the current reader (or was first heard from). False: it is
  // refused by a writer cap (now or before), and so are its samples.
  bool writer_matched(Handle writer, WriterIdentity identity, Clock::time_point now);
  // Tracked or refused: nothing more to ask Cyclone about it.
  bool knows(Handle writer) const { return writers_.count(writer) > 0 || refused_.count(writer) > 0; }
  // A device-info sample from `writer` (one not known: an unknown sender).
  void sample(Handle writer, Parsed parsed);
  // `left` was unmatched; `still_matched` is every writer the reader has now
  // (several can leave at once, a whole server, yet the status names one).
  void writer_left(Handle left, const MatchedWriters& still_matched, Clock::time_point now);
  // Exactly `left` was unmatched and no other writer came or went meanwhile (the
  // listener's status says so): no need to list every writer the reader has.
  void writer_gone(Handle left, Clock::time_point now);

  // A new reader: writers match it anew; devices whose writer has not by
  // reconcile_grace are dropped then.
  void reader_made(Clock::time_point now);
  // A new participant: what it heard about participants is forgotten too.
  void participant_made();
  // The participant is made anew because the host's network changed: a device that
  // does not come back by the reconciliation left with the network (interface-gone).
  void network_changed() { reconcile_reason_ = model::RemovalReason::interface_gone; }
  void participant_alive(const std::string& guid, Clock::time_point now);
  // A participant left or its lease expired: every writer of it is gone, so are the
  // devices it alone announced, now, whether or not its writers ever matched the
  // current reader (one made anew just before cannot see them leave).
  void participant_gone(const std::string& guid, Clock::time_point now);

  struct Due {
    bool make_reader_anew = false;  // a server's broadcast was lost: make it broadcast again
    bool refresh = false;           // a server was lost: make the participant anew
  };
  // Whether tick() at `now` reconciles, and so needs every writer the reader has
  // (listing them four times a second for nothing cost CPU with thousands).
  bool reconcile_due(Clock::time_point now) const { return reconcile_at_ && now >= *reconcile_at_; }
  // The timers: reconciliation, silent writers, lost servers. `still_matched` as
  // for writer_left(); read only when reconcile_due(now).
  Due tick(Clock::time_point now, const MatchedWriters& still_matched);
  // The soonest of the book's timers after `now` (reconciliation, writers that
  // may turn out silent, lost servers); nothing: no timer is set. Every timer the
  // book keeps has its place here, or the main loop sleeps past it.
  std::optional<Clock::time_point> next_deadline(Clock::time_point now) const;

  // The lease-expired removals since the last call (at most kMaxLeaseLosses kept:
  // a server with many devices is probed once per device's removal otherwise).
  std::vector<LeaseLoss> take_lease_losses() { return std::exchange(lease_losses_, {}); }
  static constexpr std::size_t kMaxLeaseLosses = 256;
  // How many times a removal grace is extended for a server heard again (Grace).
  static constexpr int kMaxGraceExtensions = 3;

  // Removes this domain's devices from the table (leaving the domain for good).
  void forget_devices(model::RemovalReason reason);
  // New device caps (a reload). Devices past them leave the table as `refused`,
  // the most recently found first: those listed longest are what clients hold.
  // Returns the ids removed.
  std::vector<std::string> set_device_caps(std::size_t per_participant, std::size_t per_domain);
  // The device with this topic-root as last announced (with its server), if any.
  std::optional<nlohmann::json> announcement(const std::string& topic_root) const;
  // topic-root -> the device as last announced, for every device.
  std::map<std::string, nlohmann::json> announcements() const;
  // The participants announcing the device `topic_root` (its servers: never its
  // clients); nothing when there is no such device.
  std::optional<std::set<std::string>> servers_of(const std::string& topic_root) const;
  // Whether a device with this topic-root is kept.
  bool has_device(std::string_view topic_root) const;
  // The participants a new reader must not be made before: the servers of the
  // devices kept and the lost servers (their broadcasts to a reader made before
  // Cyclone knows their writers are lost for good).
  std::set<std::string> servers_to_hear() const;
  // Who uses the device, in short, into its document (model::InUse; none while it has
  // no client). The table changes only when the summary does: a client's burst of
  // endpoints is one change. One that takes something away (a client, a stream) is
  // held for BookOptions::in_use_hold from the first such, then written as it is
  // by then (flush_in_use); one that takes nothing away is written at once.
  // True when a hold began: the main loop must tick by its end (next_deadline).
  bool set_in_use(const std::string& topic_root, const model::InUse& in_use, Clock::time_point now);
  // The held summaries whose time has come, into the table (the main loop's tick);
  // returns when the next one still held is due.
  std::optional<Clock::time_point> flush_in_use(Clock::time_point now);
  // Whether the device's notification set came whole when asked (DescriptionFetcher),
  // into its document: "ready", and "ready-stage" while not. Kept across its
  // announcements until the next fetch concludes.
  void set_readiness(const std::string& topic_root, bool ready, const std::string& stage);
  // The topic-roots of every device: all the session's tick needs each time (copying
  // every announcement instead was most of the daemon's idle CPU).
  std::set<std::string> topic_roots() const;
  std::size_t lost_servers() const { return lost_.size(); }
  // devices, accepted, stopping, rejected, lost_servers.
  void fill(DomainStatus& status) const;
  // Per participant GUID: its writers on the topic, the devices they announce,
  // and those silent past the grace (for /v1/participants).
  std::map<std::string, PublisherCounts> publishers(Clock::time_point now) const;

 private:
  struct Writer {
    WriterIdentity identity;
    Clock::time_point matched_at;
    bool sent = false;  // delivered a sample to the current reader
  };
  // A device of this domain in the table, and every writer announcing it: two
  // servers may serve one topic-root, and the device stays while either does.
  // Typed: as JSON objects, the document and its servers were several times larger,
  // the largest part of the daemon's memory with many cameras (scale10k, massif).
  struct Announced {
    std::uint64_t found = 0;  // the order devices were found in, for set_device_caps
    model::Device doc;  // as last given to the table
    // (writer GUID, that writer's server), the latest announcer last: it is the
    // one the document shows.
    std::vector<std::pair<std::string, model::Server>> announcers;
  };

  void announce(const std::string& id, const Writer* writer, model::Device doc);
  void stopping(const std::string& topic_root, const Writer* writer);
  // Drops one announcer of `id`; the device leaves the table with its last one,
  // else shows the latest remaining announcer. Returns whether it left.
  bool drop_announcer(const std::string& id, const std::string& writer_guid, model::RemovalReason reason,
                      const std::string& why);
  void remove_device(const std::string& id, model::RemovalReason reason, const std::string& why);
  void unindex(const std::string& writer_guid, const std::string& id);  // from devices_of_writer_
  // Forgets writers no longer matched; drops the announcements of those gone
  // (only of `only`, while reconciling).
  void sweep(const MatchedWriters& still_matched, const std::string* only, Clock::time_point now,
             model::RemovalReason reason = model::RemovalReason::writer_gone);
  // Drops the devices `writer_guid` announced (a writer gone); a device that left
  // with it may mean its server is lost.
  void drop_writer_devices(const std::string& writer_guid, Clock::time_point now);
  std::map<Handle, Writer>::iterator erase_writer(std::map<Handle, Writer>::iterator it);
  // Forgets the silent-writer retries of a server with no writer left, or a
  // long-lived daemon would keep an entry for every peer that ever came by.
  void forget_retries_if_gone(const std::string& participant_guid);
  void reject(const std::string& reason, const std::string& detail, const std::string& sender);
  std::string prefix() const;

  SharedTable& table_;
  BookOptions options_;
  std::map<Handle, Writer> writers_;                     // matched to the current reader
  std::map<std::string, std::size_t> writers_of_;        // writers_ counted by participant GUID
  std::unordered_set<Handle> refused_;                   // matched, over a writer cap
  std::map<std::string, std::uint64_t> writers_refused_;  // by reason
  std::map<std::string, int> silent_retries_;            // by participant GUID
  std::set<std::string> retried_writers_;                // GUIDs silent when the reader was made anew
  std::set<std::string> idle_writers_;                   // GUIDs silent for that new reader too
  std::map<std::string, Announced> devices_;             // by device id
  std::uint64_t devices_found_ = 0;
  // writer GUID -> the ids of the devices it announces: a writer leaving finds
  // its devices without a walk over every device (thousands of writers leave
  // one by one when a large server goes).
  std::map<std::string, std::set<std::string>> devices_of_writer_;
  std::map<std::string, std::size_t> per_participant_;  // devices announced, by participant GUID
  std::optional<Clock::time_point> reconcile_at_;
  std::optional<model::RemovalReason> reconcile_reason_;  // why the next reconciliation removes
  LostServers lost_;
  std::vector<LeaseLoss> lease_losses_;
  // Devices in their removal grace: device id -> when they are removed. A grace
  // is extended (heard_again_grace) when the device's server was heard again
  // within it but its device not yet: the refresh and new reader that bring it back
  // take seconds on a lossy link, and a camera heard again within the grace is not
  // removed. Each extension needs the server heard again since the last, and there
  // are kMaxGraceExtensions at most.
  struct Grace {
    Clock::time_point until;
    bool heard = false;  // its server's participant, since the grace or its last extension began
    int extensions = 0;
  };
  std::map<std::string, Grace> unresponsive_;
  // In-use summaries held (set_in_use), by device id: the latest, and when it is written.
  struct HeldInUse {
    std::optional<model::InUse> in_use;
    Clock::time_point until;
  };
  std::map<std::string, HeldInUse> in_use_held_;
  void write_in_use(const std::string& id, std::optional<model::InUse> in_use);
  void mark_unresponsive(const std::string& id, Clock::time_point now);
  void end_graces(Clock::time_point now);
  // Silent writers (silent_writers.cpp): the servers waited for, each writer's
  // grace, and whether the reader is to be made anew now.
  std::set<std::string> awaited_servers() const;
  std::chrono::milliseconds silent_grace_of(const Writer& w, const std::set<std::string>& awaited) const;
  bool ask_silent_servers_again(Clock::time_point now);
  std::uint64_t accepted_ = 0, stopping_ = 0;
  std::map<std::string, std::uint64_t> rejected_;
};

// A writer's GUID shares its participant's prefix; the participant's own entity
// id is always 000001c1 (RTPS).
std::string participant_of(const std::string& writer_guid);

}  // namespace rsd::dds
