// The device table: every device the daemon knows, a generation counter and a
// bounded change log. Plain data, no locks and no threads: SharedTable wraps it
// for the sources' and frontends' threads, and the unit tests drive it directly.
#pragma once

#include "rsd_model/device.hpp"
#include "rsd_model/removal.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace rsd {

// `described`: nothing of the device changed, but its description (Camera
// Discovery, GET /v1/devices/{id}/description) became available.
enum class EventType { added, changed, removed, described };
const char* to_string(EventType type);

// One entry of the table as every reader gets it: the typed device, whose fields the
// filters, lookups and counts read, and its JSON text, made once per change (the list
// body, GET /v1/devices/{id} and every SSE client send these very bytes). Immutable
// and shared: a snapshot or an event holds it without copying it.
struct TableEntry {
  model::Device device;
  std::string text;  // one line; invalid UTF-8 from a peer replaced, as everywhere in the API
  nlohmann::json json() const;  // parsed again: for tests and tools
};
using EntryPtr = std::shared_ptr<const TableEntry>;

struct DeviceEvent {
  std::uint64_t generation = 0;  // strictly increasing, one per event; the SSE id
  EventType type = EventType::added;
  std::string id;  // the entry's
  // The entry as it is after the event (before it, for removed): the table's own while
  // it is current. The change log keeps thousands of these; a document as a JSON
  // object takes several times its text, and the log's byte bound counts the text.
  EntryPtr entry;
  // changed: the entry before the change, so that a filtered reader can tell a
  // device leaving its filter (removed, for it) or entering it (added).
  EntryPtr previous;
  // removed: why (none for an entry that merged into another: see merged-into).
  std::optional<model::RemovalReason> reason;
  // added: the camera was gone (a gone entry, below) and is back; `away_since` is
  // when it was removed.
  bool back = false;
  std::string away_since;
  nlohmann::json device() const;  // parsed again: for tests
};

// One change of a camera's presence, as the history keeps it.
struct HistoryRecord {
  std::uint64_t generation = 0;  // the event's, so a history reader can resume
  std::string at;                // when, in the form of first-seen/last-seen
  std::string id;                // the entry's
  EventType type = EventType::added;           // added or removed
  std::optional<model::RemovalReason> reason;  // removed (not by a merge)
  bool back = false;                           // added after being gone
  bool flap = false;                           // added: back within the flap window of a lease-expired
  std::string detail;                          // removed: the source's words on why
  std::optional<model::HostVerdict> host;      // lease-expired: judged after the removal
};

// A camera that left: findable by its id, serial or topic-root until it comes back
// or is dropped (the oldest first beyond the count, or after HistoryLimits::gone_keep).
struct GoneEntry {
  EntryPtr last;  // the entry as it was last shown; its last-seen is the last sighting
  model::RemovalReason reason = model::RemovalReason::stopping;
  std::string removed_at;
  std::string detail;
  std::uint64_t generation = 0;  // of its removed event
  std::optional<model::HostVerdict> host;  // as its history record's
};

// A camera's history: its latest changes, oldest first, and how often it was removed,
// by reason (counted for as long as the table knows the camera, beyond the changes kept).
struct CameraHistory {
  std::string id;
  std::vector<HistoryRecord> changes;
  std::array<std::uint64_t, model::kRemovalReasons.size()> removals{};
  std::uint64_t flaps = 0;  // lost by lease and back within HistoryLimits::flap_window
  std::uint64_t removed(model::RemovalReason r) const { return removals[static_cast<std::size_t>(r)]; }
};

// What the table counted since it was made, for /metrics.
struct TableCounts {
  std::array<std::uint64_t, model::kRemovalReasons.size()> removals{};  // by reason
  std::uint64_t returns = 0;  // cameras added again while gone
  std::uint64_t flaps = 0;    // of those, lost by lease and back within the flap window
  std::size_t gone = 0;
  std::size_t history = 0;  // changes kept
  std::array<std::uint64_t, model::kHostVerdicts.size()> hosts{};  // lease-expired removals judged, by verdict
};

// Bounds of the history, so that cameras coming and going for months cannot grow the
// daemon: at most `per_camera` changes a camera, `total` in all (the oldest dropped
// first), `gone` gone entries (the oldest dropped first), each kept `gone_keep`.
struct HistoryLimits {
  std::size_t per_camera = 64;
  std::size_t total = 16384;
  std::size_t gone = 1024;
  std::chrono::seconds gone_keep{24 * 3600};  // SharedTable's clock applies it
  // A camera lost by lease and back within this is a flap: a lossy link or a server
  // that stalls, not a camera that went away.
  std::chrono::seconds flap_window{60};
};

// What events_since() found in the change log.
struct EventsSince {
  std::vector<DeviceEvent> events;
  // The requested generation is older than the oldest event the log still holds
  // (or newer than anything issued): the caller must re-list instead.
  bool gap = false;
};

// One camera can be seen by two sources (announced on DDS and plugged in on USB).
// Each source upserts its own *sighting* under its own id; the table shows one
// *entry* per camera. Sightings from different sources merge into one entry only
// when both carry a "source" string and the very same non-empty "serial" string
// (never on a guess). The entry then:
//   - takes the id and every field of its primary sighting: the source that comes
//     first in model::Source's order ("dds" before "usb"; a source the model does
//     not know after them, by name), lowest id among equals, so the id
//     only depends on what is seen now, not on the order it was seen in;
//   - keeps "source" = the primary's source (the sighting that names the entry) and
//     lists every source in "sources" (sorted; also set, one long, on unmerged
//     entries whose sighting has a "source");
//   - fills fields the primary lacks from the other sightings ("usb", "warnings"...);
//   - first-seen/last-seen: earliest/latest of its sightings.
// At most one sighting per source joins an entry; others stay entries of their own.
// A "remote-usb" sighting (another host's camera) never merges.
// A merge or split is told with the ordinary events: a USB-only entry that joins a
// DDS one is `removed` (its document then carries "merged-into": <entry id>) and the
// DDS entry `changed`; unplugging leaves a `changed` entry; the DDS side leaving
// `removes` the merged entry and `adds` the USB one again. find() also answers for
// the id of a sighting that is merged into another entry.
class DeviceTable {
 public:
  // Fields the table owns itself; a source's document never sets them.
  // (Spelled once, by the API's model.)
  static constexpr const char* kFirstSeen = model::key::first_seen;
  static constexpr const char* kLastSeen = model::key::last_seen;
  static constexpr const char* kSources = model::key::sources;
  static constexpr const char* kMergedInto = model::key::merged_into;

  // `first_generation` lets a restarted daemon continue above its predecessor's ids
  // (main seeds it from the clock), so a client resuming with an old id is told to
  // re-list instead of being handed unrelated events.
  // The change log keeps the last `log_capacity` events, and no more than
  // `log_max_bytes` of their documents: a burst of changes cannot grow the daemon
  // for good (a client that falls further behind re-lists). 128 KiB holds ~290
  // events of a realdds camera: hours of changes at a lab's pace, and at a soak's
  // pace (3 a second) it is full within two minutes, after which memory stays flat.
  explicit DeviceTable(std::size_t log_capacity = 4096, std::uint64_t first_generation = 0,
                       std::size_t log_max_bytes = 128 * 1024, HistoryLimits limits = {});

  // Adds the device (sighting) `id` or updates it. `doc` is the whole device as its
  // source sees it now (an object; "id" is set here). Returns the event it caused
  // on the entry that now shows this sighting, or nothing when only last-seen moved:
  // a periodic re-announcement is not news. A merge can cause more than one event
  // (see above): all go to the change log; the others are not returned.
  // `heard`: the source heard the device now, so last-seen moves; false for what the
  // daemon itself says of it meanwhile (unresponsive, in-use), which keeps last-seen.
  std::optional<DeviceEvent> upsert(const std::string& id, model::Device doc, const std::string& now_iso8601,
                                    bool heard = true);
  // The same for a source that holds its device as JSON (read once into the model).
  std::optional<DeviceEvent> upsert(const std::string& id, const nlohmann::json& doc,
                                    const std::string& now_iso8601, bool heard = true);

  // Removes the device (sighting) for `reason`; nothing happens (and no event) when it
  // is not there. Returns the event of the entry that showed it: `removed`, or `changed`
  // when the entry lives on through another source's sighting. An entry removed
  // becomes a gone entry; `detail` (the source's words) goes with it and its history.
  std::optional<DeviceEvent> remove(const std::string& id, model::RemovalReason reason,
                                    const std::string& now_iso8601, std::string detail = {});

  // Records a `described` event for the entry `id` (or the one its sighting is
  // merged into) without changing it; nothing when there is no such entry.
  std::optional<DeviceEvent> note_described(const std::string& id);

  // Removes every sighting that (as its source gave it, with "id" and the
  // timestamps) satisfies `pred`; returns every event that caused.
  std::vector<DeviceEvent> remove_if(const std::function<bool(const model::Device&)>& pred,
                                     model::RemovalReason reason, const std::string& now_iso8601);

  // The entry with this id, or the entry a sighting with this id is merged into.
  EntryPtr find(const std::string& id) const;
  std::vector<EntryPtr> entries() const;        // ordered by id
  std::vector<nlohmann::json> devices() const;  // the same, parsed again: for tests
  std::size_t size() const { return devices_.size(); }

  std::uint64_t generation() const { return generation_; }
  EventsSince events_since(std::uint64_t generation) const;

  // The gone camera `key` names: its entry id, else the latest gone one whose serial or
  // topic-root it is (model::Device::named_by). Nothing for a camera present or never seen.
  std::optional<GoneEntry> find_gone(const std::string& key) const;
  // The history of the camera `key` names: present (its id, a sighting's, a serial or a
  // topic-root), else gone (as find_gone()).
  std::optional<CameraHistory> history(const std::string& key) const;
  // Every change kept after `generation`, oldest first, at most `max`.
  std::vector<HistoryRecord> history_since(std::uint64_t generation, std::size_t max) const;
  // The verdict on the host of a camera removed by its lease (the removal of
  // generation `removal`, entry `entry_id`): into that history record and gone entry,
  // and counted. False when the table no longer keeps that removal (counted still).
  bool judge_host(const std::string& entry_id, std::uint64_t removal, model::HostVerdict verdict);
  // Drops the gone entries removed before `cutoff_iso8601` (the same form as `at`).
  void expire_gone(const std::string& cutoff_iso8601);
  std::size_t gone_size() const { return gone_.size(); }
  TableCounts counts() const;
  std::size_t history_size() const;  // changes kept, over every camera
  const HistoryLimits& limits() const { return limits_; }

 private:
  DeviceEvent record(DeviceEvent event);
  DeviceEvent record(EventType type, EntryPtr entry, EntryPtr previous = nullptr);
  // Why the sightings reconcile() looks at changed: a removal's reason, or nothing.
  struct Removal {
    model::RemovalReason reason;
    const std::string& detail;
  };
  void note(const std::string& entry_id, HistoryRecord change);
  void forget_camera_if_unknown(const std::string& entry_id);
  void drop_gone(std::map<std::string, GoneEntry>::iterator it);

  using Layout = std::map<std::string, std::vector<std::string>>;  // entry id -> sightings, primary first
  void index(const std::string& id, const model::Device& sighting, bool add);
  std::set<std::string> group_of(const std::string& sighting_id) const;
  Layout layout(const std::set<std::string>& sightings) const;
  model::Device build_entry(const std::vector<std::string>& members) const;
  // Re-derives the entries of `affected` sightings; `old_entries` are the entry ids
  // they had before the change. Emits events; returns them in log order.
  std::vector<DeviceEvent> reconcile(const std::set<std::string>& affected,
                                     const std::set<std::string>& old_entries, const std::string& now,
                                     const Removal* removal);
  std::optional<DeviceEvent> event_for(const std::vector<DeviceEvent>& events,
                                       const std::string& entry_id) const;
  std::vector<DeviceEvent> remove_sighting(const std::string& id, std::string& old_entry, const std::string& now,
                                          const Removal& removal);

  // As the sources gave them, typed: as JSON objects they were the largest part of
  // the daemon's memory per camera (bench scale10k, massif).
  std::map<std::string, model::Device> sightings_;
  std::map<std::string, std::set<std::string>> by_serial_;  // merge key -> sighting ids
  std::map<std::string, std::string> owner_;        // sighting id -> entry id
  std::map<std::string, EntryPtr> devices_;        // the entries, what everyone sees
  std::deque<DeviceEvent> log_;
  std::size_t log_capacity_;
  std::size_t log_max_bytes_;
  std::size_t log_bytes_ = 0;
  std::uint64_t generation_ = 0;

  struct Camera {
    std::deque<HistoryRecord> changes;  // ids left empty: the key says it
    std::array<std::uint64_t, model::kRemovalReasons.size()> removals{};
    std::uint64_t flaps = 0;
  };
  HistoryLimits limits_;
  TableCounts counts_;  // removals and returns; the sizes are filled by counts()
  std::map<std::string, Camera> cameras_;  // by entry id
  // (generation, entry id) of every change kept, oldest first: the total bound and
  // history_since() walk it. It may name a change the per-camera bound dropped already.
  std::deque<std::pair<std::uint64_t, std::string>> history_order_;
  std::map<std::string, GoneEntry> gone_;             // by entry id
  std::map<std::uint64_t, std::string> gone_order_;  // removal generation -> entry id
};

}  // namespace rsd
