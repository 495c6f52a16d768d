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
#include "table/shared_table.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace rsd::dds {

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
  // anew for every such server cost 1.6 s in noticing a SIGKILL (bench, measured).
  std::chrono::milliseconds silent_grace{2500};
  int silent_retries = 3;  // per server participant, so a quiet peer can't loop us
  // Caps: a realdds server announces a handful of devices, and one rogue writer
  // could announce thousands (150,000 distinct ones in 2 s, measured). Devices
  // beyond a cap are refused (counted as rejected, logged with a rate limit).
  std::size_t max_devices_per_participant = 128;
  std::size_t max_devices_per_domain = 1024;
  // After the reader or the participant is made anew, a device whose writer has
  // not matched again by then is gone. Matching a settled participant's writers
  // takes milliseconds; the grace is also how late a server killed during a
  // refresh is noticed (it cannot unmatch a reader it never matched).
  std::chrono::milliseconds reconcile_grace{2000};
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
  using Handle = std::uint64_t;  // the reader's instance handle of a writer

  DomainBook(SharedTable& table, BookOptions options);

  // A writer matched the current reader (or was first heard from).
  void writer_matched(Handle writer, WriterIdentity identity, Clock::time_point now);
  bool knows(Handle writer) const { return writers_.count(writer) > 0; }
  // A device-info sample from `writer` (one not known: an unknown sender).
  void sample(Handle writer, Parsed parsed);
  // `left` was unmatched; `still_matched` is every writer the reader has now
  // (several can leave at once, a whole server, yet the status names one).
  void writer_left(Handle left, const std::set<Handle>& still_matched, Clock::time_point now);

  // A new reader: writers match it anew; devices whose writer has not by
  // reconcile_grace are dropped then.
  void reader_made(Clock::time_point now);
  // A new participant: what it heard about participants is forgotten too.
  void participant_made();
  void participant_alive(const std::string& guid, Clock::time_point now) { lost_.participant_alive(guid, now); }
  // A participant left or its lease expired: every writer of it is gone, so are the
  // devices it alone announced, now, whether or not its writers ever matched the
  // current reader (one made anew just before cannot see them leave).
  void participant_gone(const std::string& guid, Clock::time_point now);

  struct Due {
    bool make_reader_anew = false;  // a server's broadcast was lost: make it broadcast again
    bool refresh = false;           // a server was lost: make the participant anew
  };
  // The timers: reconciliation, silent writers, lost servers. `still_matched` as
  // for writer_left().
  Due tick(Clock::time_point now, const std::set<Handle>& still_matched);

  // Removes this domain's devices from the table (leaving the domain for good).
  void forget_devices();
  // The device with this topic-root as last announced (with its server), if any.
  std::optional<nlohmann::json> announcement(const std::string& topic_root) const;
  // topic-root -> the device as last announced, for every device.
  std::map<std::string, nlohmann::json> announcements() const;
  // The topic-roots of every device: all the session's tick needs each time (copying
  // every announcement instead was most of the daemon's idle CPU).
  std::set<std::string> topic_roots() const;
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
  struct Announced {
    nlohmann::json doc;  // as last given to the table
    // (writer GUID, that writer's "server" object), the latest announcer last:
    // it is the one the document shows.
    std::vector<std::pair<std::string, nlohmann::json>> announcers;
  };

  void announce(const std::string& id, const Writer* writer, nlohmann::json doc);
  void stopping(const std::string& topic_root, const Writer* writer);
  // Drops one announcer of `id`; the device leaves the table with its last one,
  // else shows the latest remaining announcer. Returns whether it left.
  bool drop_announcer(const std::string& id, const std::string& writer_guid, const std::string& why);
  void remove_device(const std::string& id, const std::string& why);
  // Forgets writers no longer matched; drops the announcements of those gone
  // (only of `only`, while reconciling).
  void sweep(const std::set<Handle>& still_matched, const std::string* only, Clock::time_point now);
  void reject(const std::string& reason, const std::string& detail, const std::string& sender);
  std::string prefix() const;

  SharedTable& table_;
  BookOptions options_;
  std::map<Handle, Writer> writers_;                     // matched to the current reader
  std::map<std::string, int> silent_retries_;            // by participant GUID
  std::set<std::string> retried_writers_;                // GUIDs silent when the reader was made anew
  std::set<std::string> idle_writers_;                   // GUIDs silent for that new reader too
  std::map<std::string, Announced> devices_;             // by device id
  std::map<std::string, std::size_t> per_participant_;  // devices announced, by participant GUID
  std::optional<Clock::time_point> reconcile_at_;
  LostServers lost_;
  std::uint64_t accepted_ = 0, stopping_ = 0;
  std::map<std::string, std::uint64_t> rejected_;
};

// A writer's GUID shares its participant's prefix; the participant's own entity
// id is always 000001c1 (RTPS).
std::string participant_of(const std::string& writer_guid);

}  // namespace rsd::dds
