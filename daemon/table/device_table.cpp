#include "table/device_table.hpp"

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <utility>
#include <iterator>
#include <limits>

namespace rsd {

const char* to_string(EventType type) {
  switch (type) {
    case EventType::added: return "added";
    case EventType::changed: return "changed";
    case EventType::removed: return "removed";
    case EventType::described: return "described";
  }
  return "unknown";
}

DeviceTable::DeviceTable(std::size_t log_capacity, std::uint64_t first_generation, std::size_t log_max_bytes,
                         HistoryLimits limits)
    : log_capacity_(std::max<std::size_t>(1, log_capacity)), log_max_bytes_(log_max_bytes),
      generation_(first_generation), limits_(limits) {
  limits_.per_camera = std::max<std::size_t>(1, limits_.per_camera);
  limits_.total = std::max<std::size_t>(1, limits_.total);
}

nlohmann::json TableEntry::json() const { return nlohmann::json::parse(text); }

nlohmann::json DeviceEvent::device() const { return entry ? entry->json() : nlohmann::json(); }

namespace {
// Two documents describe the same state when they differ only in the timestamps.
bool same_but_timestamps(const model::Device& a, model::Device b) {
  b.first_seen = a.first_seen;
  b.last_seen = a.last_seen;
  return a == b;
}

// Milliseconds since the epoch of a time in the form of first-seen/last-seen; nothing
// for another form (the unit tests' made-up times).
std::optional<std::int64_t> epoch_ms(const std::string& t) {
  std::tm tm{};
  int ms = 0;
  if (std::sscanf(t.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d.%3dZ", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour,
                  &tm.tm_min, &tm.tm_sec, &ms) != 7)
    return std::nullopt;
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  return static_cast<std::int64_t>(timegm(&tm)) * 1000 + ms;
}

// Sources in the order in which they name a merged entry: the model's (dds, usb), then
// any other by name.
std::pair<std::size_t, std::string> source_rank(const std::string& source) {
  if (const auto known = model::parse_source(source)) return {static_cast<std::size_t>(*known), source};
  return {std::numeric_limits<std::size_t>::max(), source};
}

// The entry readers get: serialized once, here, per change.
EntryPtr make_entry(model::Device device) {
  std::string text = model::to_json(device).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return std::make_shared<const TableEntry>(TableEntry{std::move(device), std::move(text)});
}

// A key the table owns, cleared from a source's sighting: typed, and from `extra`
// (where a value of another type than the model's would be).
void clear_owned(model::Device& d) {
  d.sources.clear();
  d.merged_into.reset();
  for (const char* k : {model::key::id, model::key::sources, model::key::merged_into, model::key::first_seen,
                        model::key::last_seen, model::key::reason, model::key::arrival, model::key::away_since})
    d.extra.erase(k);
}

const std::string* string_field(const nlohmann::json& doc, const char* key) {
  auto it = doc.find(key);
  if (it == doc.end() || !it->is_string()) return nullptr;
  return it->get_ptr<const std::string*>();
}

// The source a sighting names: the model's, or another one by its name (kept in
// `extra`, as every value the model has no type for).
std::optional<std::string> source_name(const model::Device& sighting) {
  if (sighting.source) return std::string(model::to_string(*sighting.source));
  const auto it = sighting.extra.find(model::key::source);
  if (it == sighting.extra.end() || !it->is_string()) return std::nullopt;
  return it->get<std::string>();
}

// The key on which sightings may merge: the exact serial of a sighting that says
// which source it comes from. Nothing else (no prefixes, no case folding).
std::optional<std::string> merge_key(const model::Device& sighting) {
  const auto source = source_name(sighting);
  if (!source || source->empty() || !sighting.serial || sighting.serial->empty()) return std::nullopt;
  // Another host's camera is never this host's, nor a third host's with the same
  // serial: each host's sighting stays an entry of its own.
  if (sighting.source == model::Source::remote_usb) return std::nullopt;
  return *sighting.serial;
}
}  // namespace

void DeviceTable::index(const std::string& id, const model::Device& sighting, bool add) {
  auto key = merge_key(sighting);
  if (!key) return;
  if (add) {
    by_serial_[*key].insert(id);
    return;
  }
  auto it = by_serial_.find(*key);
  if (it == by_serial_.end()) return;
  it->second.erase(id);
  if (it->second.empty()) by_serial_.erase(it);
}

std::set<std::string> DeviceTable::group_of(const std::string& sighting_id) const {
  std::set<std::string> out{sighting_id};
  auto s = sightings_.find(sighting_id);
  if (s == sightings_.end()) return out;
  if (auto key = merge_key(s->second)) {
    auto it = by_serial_.find(*key);
    if (it != by_serial_.end()) out.insert(it->second.begin(), it->second.end());
  }
  return out;
}

DeviceTable::Layout DeviceTable::layout(const std::set<std::string>& sightings) const {
  Layout out;
  std::map<std::string, std::vector<std::string>> groups;  // serial -> ids (sorted)
  for (const auto& id : sightings) {
    auto s = sightings_.find(id);
    if (s == sightings_.end()) continue;
    if (auto key = merge_key(s->second))
      groups[*key].push_back(id);
    else
      out[id] = {id};
  }
  for (const auto& [serial, ids] : groups) {
    // The lowest id of each source takes part; the first source names the entry.
    std::map<std::pair<std::size_t, std::string>, std::string> first_of_source;
    for (const auto& id : ids) {
      const auto rank = source_rank(*source_name(sightings_.at(id)));
      first_of_source.emplace(rank, id);  // ids are sorted: the first one stays
    }
    std::vector<std::string> members;
    for (const auto& [rank, id] : first_of_source) members.push_back(id);
    for (const auto& id : ids)
      if (std::find(members.begin(), members.end(), id) == members.end()) out[id] = {id};
    out[members.front()] = members;
  }
  return out;
}

model::Device DeviceTable::build_entry(const std::vector<std::string>& members) const {
  const model::Device& primary = sightings_.at(members.front());
  // The common case, a camera seen by one source the model knows: the sighting itself.
  if (members.size() == 1 && (primary.source || !primary.extra.contains(model::key::source))) {
    model::Device entry = primary;
    if (primary.source) entry.sources = {*primary.source};
    return entry;
  }
  nlohmann::json entry = model::to_json(primary);
  const bool sourced = string_field(entry, model::key::source) != nullptr;
  std::set<std::string> sources;
  if (sourced) sources.insert(*string_field(entry, model::key::source));
  for (std::size_t i = 1; i < members.size(); ++i) {
    const nlohmann::json other = model::to_json(sightings_.at(members[i]));
    if (const auto* src = string_field(other, model::key::source)) sources.insert(*src);
    for (const auto& [key, value] : other.items()) {
      if (key == model::key::id || key == model::key::source || key == kSources || key == kFirstSeen ||
          key == kLastSeen || entry.contains(key))
        continue;
      entry[key] = value;
    }
    const auto first = other.value(kFirstSeen, std::string());
    const auto last = other.value(kLastSeen, std::string());
    if (first < entry.value(kFirstSeen, first)) entry[kFirstSeen] = first;
    if (last > entry.value(kLastSeen, last)) entry[kLastSeen] = last;
  }
  if (sourced) entry[kSources] = sources;
  return model::device_from_json(entry);
}

std::vector<DeviceEvent> DeviceTable::reconcile(const std::set<std::string>& affected,
                                                const std::set<std::string>& old_entries, const std::string& now,
                                                const Removal* removal) {
  const Layout next = layout(affected);
  std::vector<DeviceEvent> events;
  // Removals first, so an event stream never shows one camera twice.
  for (const auto& entry_id : old_entries) {
    if (next.count(entry_id)) continue;
    auto it = devices_.find(entry_id);
    if (it == devices_.end()) continue;
    DeviceEvent removed;
    removed.type = EventType::removed;
    removed.entry = std::move(it->second);
    devices_.erase(it);
    bool merged = false;
    for (const auto& [id, members] : next)
      if (std::find(members.begin(), members.end(), entry_id) != members.end()) {
        model::Device doc = removed.entry->device;
        doc.merged_into = id;
        removed.entry = make_entry(std::move(doc));
        merged = true;
      }
    // A merge is no departure: the camera is still listed, under the entry it joined.
    if (!merged && removal) {
      removed.reason = removal->reason;
      ++counts_.removals[static_cast<std::size_t>(removal->reason)];
    }
    events.push_back(record(std::move(removed)));
    if (!events.back().reason) continue;
    const DeviceEvent& ev = events.back();
    note(entry_id,
         HistoryRecord{ev.generation, now, {}, EventType::removed, ev.reason, false, false, removal->detail, {}});
    gone_[entry_id] = GoneEntry{ev.entry, *ev.reason, now, removal->detail, ev.generation, {}};
    gone_order_[ev.generation] = entry_id;
    while (gone_.size() > limits_.gone) drop_gone(gone_.find(gone_order_.begin()->second));
  }
  for (const auto& [entry_id, members] : next) {
    for (const auto& m : members) owner_[m] = entry_id;
    model::Device doc = build_entry(members);
    auto it = devices_.find(entry_id);
    if (it == devices_.end()) {
      DeviceEvent added;
      added.type = EventType::added;
      added.entry = devices_.emplace(entry_id, make_entry(std::move(doc))).first->second;
      bool flap = false;
      if (const auto gone = gone_.find(entry_id); gone != gone_.end()) {
        added.back = true;
        ++counts_.returns;
        added.away_since = gone->second.removed_at;
        const auto from = epoch_ms(gone->second.removed_at), to = epoch_ms(now);
        flap = gone->second.reason == model::RemovalReason::lease_expired && from && to &&
               *to - *from <= std::chrono::milliseconds(limits_.flap_window).count();
        drop_gone(gone);
      }
      events.push_back(record(std::move(added)));
      if (flap) {
        ++counts_.flaps;
        ++cameras_[entry_id].flaps;
      }
      note(entry_id, HistoryRecord{events.back().generation, now, {}, EventType::added, std::nullopt,
                                   events.back().back, flap, {}, {}});
      continue;
    }
    const bool changed = !same_but_timestamps(it->second->device, doc);
    EntryPtr before = std::exchange(it->second, make_entry(std::move(doc)));
    if (changed) events.push_back(record(EventType::changed, it->second, std::move(before)));
  }
  return events;
}

std::optional<DeviceEvent> DeviceTable::event_for(const std::vector<DeviceEvent>& events,
                                                  const std::string& entry_id) const {
  for (const auto& e : events)
    if (e.id == entry_id) return e;
  return std::nullopt;
}

std::optional<DeviceEvent> DeviceTable::upsert(const std::string& id, const nlohmann::json& doc,
                                               const std::string& now, bool heard) {
  return upsert(id, doc.is_object() ? model::device_from_json(doc) : model::Device{}, now, heard);
}

std::optional<DeviceEvent> DeviceTable::upsert(const std::string& id, model::Device sighting, const std::string& now,
                                               bool heard) {
  clear_owned(sighting);
  sighting.id = id;
  sighting.last_seen = now;
  std::set<std::string> affected = group_of(id);
  auto old = sightings_.find(id);
  if (old == sightings_.end()) {
    sighting.first_seen = now;
  } else {
    sighting.first_seen = old->second.first_seen.value_or(now);
    if (!heard && old->second.last_seen) sighting.last_seen = *old->second.last_seen;
    index(id, old->second, false);
  }
  index(id, sighting, true);
  sightings_[id] = std::move(sighting);
  for (const auto& other : group_of(id)) affected.insert(other);
  std::set<std::string> old_entries;
  for (const auto& s : affected)
    if (auto o = owner_.find(s); o != owner_.end()) old_entries.insert(o->second);
  auto events = reconcile(affected, old_entries, now, nullptr);
  return event_for(events, owner_.at(id));
}

std::vector<DeviceEvent> DeviceTable::remove_sighting(const std::string& id, std::string& old_entry,
                                                      const std::string& now, const Removal& removal) {
  std::set<std::string> affected = group_of(id);
  std::set<std::string> old_entries;
  for (const auto& s : affected)
    if (auto o = owner_.find(s); o != owner_.end()) old_entries.insert(o->second);
  old_entry = owner_.at(id);
  auto it = sightings_.find(id);
  index(id, it->second, false);
  sightings_.erase(it);
  owner_.erase(id);
  affected.erase(id);
  return reconcile(affected, old_entries, now, &removal);
}

std::optional<DeviceEvent> DeviceTable::remove(const std::string& id, model::RemovalReason reason,
                                               const std::string& now, std::string detail) {
  if (!sightings_.count(id)) return std::nullopt;
  std::string old_entry;
  auto events = remove_sighting(id, old_entry, now, Removal{reason, detail});
  return event_for(events, old_entry);
}

std::vector<DeviceEvent> DeviceTable::remove_if(const std::function<bool(const model::Device&)>& pred,
                                                model::RemovalReason reason, const std::string& now) {
  std::vector<std::string> doomed;
  for (const auto& [id, sighting] : sightings_)
    if (pred(sighting)) doomed.push_back(id);
  std::vector<DeviceEvent> events;
  const std::string no_detail;
  for (const auto& id : doomed) {
    std::string old_entry;
    auto more = remove_sighting(id, old_entry, now, Removal{reason, no_detail});
    events.insert(events.end(), more.begin(), more.end());
  }
  return events;
}

EntryPtr DeviceTable::find(const std::string& id) const {
  auto it = devices_.find(id);
  if (it != devices_.end()) return it->second;
  auto o = owner_.find(id);
  if (o == owner_.end()) return nullptr;
  it = devices_.find(o->second);
  return it == devices_.end() ? nullptr : it->second;
}

std::vector<EntryPtr> DeviceTable::entries() const {
  std::vector<EntryPtr> out;
  out.reserve(devices_.size());
  for (const auto& [id, entry] : devices_) out.push_back(entry);
  return out;
}

std::vector<nlohmann::json> DeviceTable::devices() const {
  std::vector<nlohmann::json> out;
  out.reserve(devices_.size());
  for (const auto& [id, entry] : devices_) out.push_back(entry->json());
  return out;
}

EventsSince DeviceTable::events_since(std::uint64_t generation) const {
  EventsSince out;
  if (generation > generation_) {  // a generation we never issued: another daemon's, or ours before a restart
    out.gap = true;
    return out;
  }
  if (generation == generation_) return out;
  // The log holds generations [front, generation_]; resuming needs generation+1 in it.
  if (log_.empty() || log_.front().generation > generation + 1) {
    out.gap = true;
    return out;
  }
  auto first = std::lower_bound(log_.begin(), log_.end(), generation + 1,
                                [](const DeviceEvent& e, std::uint64_t g) { return e.generation < g; });
  out.events.assign(first, log_.end());
  return out;
}

std::optional<DeviceEvent> DeviceTable::note_described(const std::string& id) {
  EntryPtr entry = find(id);
  if (!entry) return std::nullopt;
  return record(EventType::described, std::move(entry));
}

DeviceEvent DeviceTable::record(EventType type, EntryPtr entry, EntryPtr previous) {
  DeviceEvent event;
  event.type = type;
  event.entry = std::move(entry);
  event.previous = std::move(previous);
  return record(std::move(event));
}

DeviceEvent DeviceTable::record(DeviceEvent event) {
  event.generation = ++generation_;
  event.id = event.entry->device.id;
  log_.push_back(event);
  log_bytes_ += event.entry->text.size();
  // The newest event always stays, whatever its size: a resume from just before it works.
  while (log_.size() > 1 && (log_.size() > log_capacity_ || log_bytes_ > log_max_bytes_)) {
    log_bytes_ -= log_.front().entry->text.size();
    log_.pop_front();
  }
  return event;
}

void DeviceTable::note(const std::string& entry_id, HistoryRecord change) {
  Camera& camera = cameras_[entry_id];
  if (change.type == EventType::removed && change.reason) ++camera.removals[static_cast<std::size_t>(*change.reason)];
  history_order_.emplace_back(change.generation, entry_id);
  camera.changes.push_back(std::move(change));
  if (camera.changes.size() > limits_.per_camera) camera.changes.pop_front();
  while (history_order_.size() > limits_.total) {
    const auto [generation, id] = std::move(history_order_.front());
    history_order_.pop_front();
    const auto c = cameras_.find(id);
    if (c == cameras_.end()) continue;
    auto& changes = c->second.changes;
    if (!changes.empty() && changes.front().generation == generation) changes.pop_front();
    if (changes.empty()) forget_camera_if_unknown(id);
  }
}

// A camera neither listed nor gone, with no change left, is forgotten with its counts:
// so the cameras the table knows are bounded by the entries, the gone and the changes.
void DeviceTable::forget_camera_if_unknown(const std::string& entry_id) {
  if (devices_.count(entry_id) || gone_.count(entry_id)) return;
  if (const auto c = cameras_.find(entry_id); c != cameras_.end() && c->second.changes.empty()) cameras_.erase(c);
}

void DeviceTable::drop_gone(std::map<std::string, GoneEntry>::iterator it) {
  const std::string id = it->first;
  gone_order_.erase(it->second.generation);
  gone_.erase(it);
  forget_camera_if_unknown(id);
}

void DeviceTable::expire_gone(const std::string& cutoff) {
  while (!gone_order_.empty()) {
    const auto it = gone_.find(gone_order_.begin()->second);
    if (it->second.removed_at >= cutoff) return;
    drop_gone(it);
  }
}

std::optional<GoneEntry> DeviceTable::find_gone(const std::string& key) const {
  if (const auto it = gone_.find(key); it != gone_.end()) return it->second;
  for (auto it = gone_order_.rbegin(); it != gone_order_.rend(); ++it) {
    const GoneEntry& gone = gone_.at(it->second);
    if (gone.last->device.named_by(key)) return gone;
  }
  return std::nullopt;
}

std::optional<CameraHistory> DeviceTable::history(const std::string& key) const {
  std::string id;
  if (const auto entry = find(key)) id = entry->device.id;
  for (auto it = devices_.begin(); id.empty() && it != devices_.end(); ++it)
    if (it->second->device.named_by(key)) id = it->first;
  if (id.empty())
    if (const auto gone = find_gone(key)) id = gone->last->device.id;
  if (id.empty() && cameras_.count(key)) id = key;
  if (id.empty()) return std::nullopt;
  CameraHistory out;
  out.id = id;
  if (const auto c = cameras_.find(id); c != cameras_.end()) {
    out.removals = c->second.removals;
    out.flaps = c->second.flaps;
    for (HistoryRecord change : c->second.changes) {
      change.id = id;
      out.changes.push_back(std::move(change));
    }
  }
  return out;
}

std::vector<HistoryRecord> DeviceTable::history_since(std::uint64_t generation, std::size_t max) const {
  std::vector<HistoryRecord> out;
  auto it = std::upper_bound(history_order_.begin(), history_order_.end(), generation,
                             [](std::uint64_t g, const auto& kept) { return g < kept.first; });
  for (; it != history_order_.end() && out.size() < max; ++it) {
    const auto c = cameras_.find(it->second);
    if (c == cameras_.end()) continue;
    const auto& changes = c->second.changes;
    const auto found = std::lower_bound(changes.begin(), changes.end(), it->first,
                                        [](const HistoryRecord& r, std::uint64_t g) { return r.generation < g; });
    if (found == changes.end() || found->generation != it->first) continue;  // dropped by the per-camera bound
    out.push_back(*found);
    out.back().id = it->second;
  }
  return out;
}

TableCounts DeviceTable::counts() const {
  TableCounts out = counts_;
  out.gone = gone_.size();
  out.history = history_size();
  return out;
}

std::size_t DeviceTable::history_size() const {
  std::size_t n = 0;
  for (const auto& [id, camera] : cameras_) n += camera.changes.size();
  return n;
}

}  // namespace rsd
