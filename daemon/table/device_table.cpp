#include "table/device_table.hpp"

#include <algorithm>
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

DeviceTable::DeviceTable(std::size_t log_capacity, std::uint64_t first_generation, std::size_t log_max_bytes)
    : log_capacity_(std::max<std::size_t>(1, log_capacity)), log_max_bytes_(log_max_bytes),
      generation_(first_generation) {}

nlohmann::json TableEntry::json() const { return nlohmann::json::parse(text); }

nlohmann::json DeviceEvent::device() const { return entry ? entry->json() : nlohmann::json(); }

namespace {
// Two documents describe the same state when they differ only in the timestamps.
bool same_but_timestamps(const nlohmann::json& a, const nlohmann::json& b) {
  nlohmann::json x = a, y = b;
  for (auto* d : {&x, &y}) {
    d->erase(DeviceTable::kFirstSeen);
    d->erase(DeviceTable::kLastSeen);
  }
  return x == y;
}

// Sources in the order in which they name a merged entry: the model's (dds, usb), then
// any other by name.
std::pair<std::size_t, std::string> source_rank(const std::string& source) {
  if (const auto known = model::parse_source(source)) return {static_cast<std::size_t>(*known), source};
  return {std::numeric_limits<std::size_t>::max(), source};
}

// The entry readers get: typed once and serialized once, here, per change.
EntryPtr make_entry(const nlohmann::json& doc) {
  return std::make_shared<const TableEntry>(
      TableEntry{model::device_from_json(doc), doc.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)});
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
  // serial (issue 25): each host's sighting stays an entry of its own.
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

nlohmann::json DeviceTable::build_entry(const std::vector<std::string>& members) const {
  nlohmann::json entry = model::to_json(sightings_.at(members.front()));
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
  return entry;
}

std::vector<DeviceEvent> DeviceTable::reconcile(const std::set<std::string>& affected,
                                                const std::set<std::string>& old_entries) {
  const Layout next = layout(affected);
  std::vector<DeviceEvent> events;
  // Removals first, so an event stream never shows one camera twice.
  for (const auto& entry_id : old_entries) {
    if (next.count(entry_id)) continue;
    auto it = devices_.find(entry_id);
    if (it == devices_.end()) continue;
    EntryPtr last = std::move(it->second);
    devices_.erase(it);
    for (const auto& [id, members] : next)
      if (std::find(members.begin(), members.end(), entry_id) != members.end()) {
        nlohmann::json doc = model::to_json(last->device);
        doc[kMergedInto] = id;
        last = make_entry(doc);
      }
    events.push_back(record(EventType::removed, std::move(last)));
  }
  for (const auto& [entry_id, members] : next) {
    for (const auto& m : members) owner_[m] = entry_id;
    nlohmann::json doc = build_entry(members);
    auto it = devices_.find(entry_id);
    if (it == devices_.end()) {
      const auto& stored = devices_.emplace(entry_id, make_entry(doc)).first->second;
      events.push_back(record(EventType::added, stored));
      continue;
    }
    const bool changed = !same_but_timestamps(model::to_json(it->second->device), doc);
    EntryPtr before = std::exchange(it->second, make_entry(doc));
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

std::optional<DeviceEvent> DeviceTable::upsert(const std::string& id, nlohmann::json doc,
                                               const std::string& now) {
  if (!doc.is_object()) doc = nlohmann::json::object();
  doc.erase(kSources);
  doc.erase(kMergedInto);
  doc[model::key::id] = id;
  doc[kLastSeen] = now;
  std::set<std::string> affected = group_of(id);
  auto old = sightings_.find(id);
  if (old == sightings_.end()) {
    doc[kFirstSeen] = now;
  } else {
    doc[kFirstSeen] = old->second.first_seen.value_or(now);
    index(id, old->second, false);
  }
  model::Device sighting = model::device_from_json(doc);
  index(id, sighting, true);
  sightings_[id] = std::move(sighting);
  for (const auto& other : group_of(id)) affected.insert(other);
  std::set<std::string> old_entries;
  for (const auto& s : affected)
    if (auto o = owner_.find(s); o != owner_.end()) old_entries.insert(o->second);
  auto events = reconcile(affected, old_entries);
  return event_for(events, owner_.at(id));
}

std::vector<DeviceEvent> DeviceTable::remove_sighting(const std::string& id,
                                                      std::string& old_entry) {
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
  return reconcile(affected, old_entries);
}

std::optional<DeviceEvent> DeviceTable::remove(const std::string& id) {
  if (!sightings_.count(id)) return std::nullopt;
  std::string old_entry;
  auto events = remove_sighting(id, old_entry);
  return event_for(events, old_entry);
}

std::vector<DeviceEvent> DeviceTable::remove_if(
    const std::function<bool(const model::Device&)>& pred) {
  std::vector<std::string> doomed;
  for (const auto& [id, sighting] : sightings_)
    if (pred(sighting)) doomed.push_back(id);
  std::vector<DeviceEvent> events;
  for (const auto& id : doomed) {
    std::string old_entry;
    auto more = remove_sighting(id, old_entry);
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
  DeviceEvent event{++generation_, type, entry->device.id, std::move(entry), std::move(previous)};
  log_.push_back(event);
  log_bytes_ += event.entry->text.size();
  // The newest event always stays, whatever its size: a resume from just before it works.
  while (log_.size() > 1 && (log_.size() > log_capacity_ || log_bytes_ > log_max_bytes_)) {
    log_bytes_ -= log_.front().entry->text.size();
    log_.pop_front();
  }
  return event;
}

}  // namespace rsd
