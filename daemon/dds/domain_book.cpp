#include "dds/domain_book.hpp"

#include "rsd_model/device.hpp"

#include "log/log.hpp"
#include "status/reasons.hpp"

#include <algorithm>

namespace rsd::dds {
namespace {

log::RateLimiter g_reject_log;

}  // namespace

std::string participant_of(const std::string& writer_guid) {
  return writer_guid.size() == 35 ? writer_guid.substr(0, 27) + "000001c1" : writer_guid;
}

DomainBook::DomainBook(SharedTable& table, BookOptions options)
    : table_(table), options_(std::move(options)), lost_(options_.lost) {}

std::string DomainBook::prefix() const { return log::domain_prefix(options_.domain); }

MatchedWriters::MatchedWriters(std::vector<WriterHandle> handles) : handles_(std::move(handles)) {
  std::sort(handles_.begin(), handles_.end());
  handles_.erase(std::unique(handles_.begin(), handles_.end()), handles_.end());
}

bool MatchedWriters::contains(WriterHandle handle) const {
  return std::binary_search(handles_.begin(), handles_.end(), handle);
}

bool DomainBook::writer_matched(Handle writer, WriterIdentity identity, Clock::time_point now) {
  if (writers_.count(writer)) return true;
  if (refused_.count(writer)) return false;
  std::string reason, detail;
  if (writers_.size() >= options_.max_writers_per_domain) {
    reason = kDomainWriterLimit;
    detail = "the domain has " + std::to_string(writers_.size()) + " device-info writers already";
  } else if (const auto n = writers_of_.find(identity.participant_guid);
             n != writers_of_.end() && n->second >= options_.max_writers_per_participant) {
    reason = kParticipantWriterLimit;
    detail = "its participant has " + std::to_string(n->second) + " device-info writers already";
  }
  if (!reason.empty()) {
    refused_.insert(writer);
    ++writers_refused_[reason];
    std::uint64_t suppressed = 0;
    if (g_reject_log.allow(std::to_string(options_.domain) + "/" + identity.participant_guid + "/" + reason,
                           suppressed))
      log::warning(prefix() + "refused device-info writer " + identity.guid + " of " + identity.participant_guid +
                   " (" + identity.participant_name + "): " + reason + " (" + detail + ")" +
                   (suppressed ? "; " + std::to_string(suppressed) + " more like it suppressed" : ""));
    return false;
  }
  log::debug([&] {
    return prefix() + "writer " + identity.guid + " of " + identity.participant_guid + " (" +
           identity.participant_name + ") matched";
  });
  ++writers_of_[identity.participant_guid];
  writers_.emplace(writer, Writer{std::move(identity), now, false});
  return true;
}

std::map<DomainBook::Handle, DomainBook::Writer>::iterator DomainBook::erase_writer(
    std::map<Handle, Writer>::iterator it) {
  if (auto n = writers_of_.find(it->second.identity.participant_guid); n != writers_of_.end() && --n->second == 0)
    writers_of_.erase(n);
  return writers_.erase(it);
}

void DomainBook::sample(Handle handle, Parsed parsed) {
  if (refused_.count(handle)) {  // counted once as a writer; its messages in bulk
    ++rejected_[kRefusedWriter];
    return;
  }
  Writer* writer = nullptr;
  if (auto it = writers_.find(handle); it != writers_.end()) writer = &it->second;
  const std::string sender = writer ? writer->identity.guid : "unknown writer";
  if (writer) writer->sent = true;

  if (auto* bad = std::get_if<Rejected>(&parsed)) {
    reject(bad->reason, bad->detail, sender);
    return;
  }
  if (auto* stop = std::get_if<Stopping>(&parsed)) {
    ++stopping_;
    log::info(prefix() + stop->topic_root + " is stopping (from " + sender + ")");
    stopping(stop->topic_root, writer);
    return;
  }
  auto& info = std::get<DeviceInfo>(parsed);
  const std::string id = device_id(options_.domain, info.topic_root);
  if (!devices_.count(id)) {
    if (devices_.size() >= options_.max_devices_per_domain) {
      reject(kDomainDeviceLimit, "the domain has " + std::to_string(devices_.size()) + " devices already",
             sender);
      return;
    }
    if (writer) {
      const std::size_t n = per_participant_[writer->identity.participant_guid];
      if (n >= options_.max_devices_per_participant) {
        reject(kParticipantDeviceLimit, "its participant announces " + std::to_string(n) + " devices already",
               sender);
        return;
      }
    }
  }
  // The device-info verbatim, read once into the API's model, with what the daemon
  // adds. What the daemon says of a camera (its server, who uses it, whether it is
  // ready or unresponsive) is never taken from the camera's own message.
  for (const char* daemons : {model::key::server, model::key::unresponsive, model::key::in_use, model::key::ready,
                              model::key::ready_stage})
    info.fields.erase(daemons);
  model::Device device = model::device_from_json(info.fields);
  device.source = model::Source::dds;
  device.domain = options_.domain;
  device.topic_root = info.topic_root;
  device.recovery = device.recovery.value_or(false);
  ++accepted_;
  announce(id, writer, std::move(device));
}

void DomainBook::announce(const std::string& id, const Writer* writer, model::Device doc) {
  Announced& device = devices_[id];
  if (device.found == 0) device.found = ++devices_found_;
  doc.server = model::Server{};
  if (writer) {
    const WriterIdentity& w = writer->identity;
    model::Server typed{w.participant_guid, w.participant_name, w.addresses, w.guid};
    doc.server = typed;
    lost_.announced(w.participant_guid);  // found again, if it was lost
    auto& list = device.announcers;
    const auto it = std::find_if(list.begin(), list.end(), [&](const auto& a) { return a.first == w.guid; });
    if (it != list.end()) list.erase(it);
    else ++per_participant_[w.participant_guid];
    list.emplace_back(w.guid, std::move(typed));  // the latest announcer is shown
    devices_of_writer_[w.guid].insert(id);
  }
  if (unresponsive_.erase(id)) log::info(prefix() + "device " + id + " heard again within the removal grace: kept");
  // Who uses it stays across announcements; so does whether it is ready, known until a
  // fetch for the new announcement concludes.
  doc.in_use = device.doc.in_use;
  doc.ready = device.doc.ready;
  doc.ready_stage = device.doc.ready_stage;
  device.doc = doc;
  if (auto ev = table_.upsert(id, std::move(doc)); ev && ev->type == EventType::added)
    log::info(prefix() + "device " + id + " added (from " + (writer ? writer->identity.guid : "unknown writer") +
              ")");
}

void DomainBook::stopping(const std::string& topic_root, const Writer* writer) {
  const std::string id = device_id(options_.domain, topic_root);
  auto it = devices_.find(id);
  if (it == devices_.end()) return;
  auto& list = it->second.announcers;
  if (writer && std::any_of(list.begin(), list.end(), [&](const auto& a) { return a.first == writer->identity.guid; })) {
    drop_announcer(id, writer->identity.guid, model::RemovalReason::stopping, "its server is stopping");
    return;
  }
  // From a writer that never announced it (or an unknown one): the device goes
  // all the same, as realdds itself does with any 'stopping'.
  for (const auto& [guid, server] : list)
    if (auto n = per_participant_.find(participant_of(guid)); n != per_participant_.end() && --n->second == 0)
      per_participant_.erase(n);
  remove_device(id, model::RemovalReason::stopping, "a server says it is stopping");
}

bool DomainBook::drop_announcer(const std::string& id, const std::string& writer_guid, model::RemovalReason reason,
                                const std::string& why) {
  auto dev = devices_.find(id);
  if (dev == devices_.end()) return true;
  auto& list = dev->second.announcers;
  const auto it = std::find_if(list.begin(), list.end(), [&](const auto& a) { return a.first == writer_guid; });
  if (it == list.end()) return false;
  if (auto n = per_participant_.find(participant_of(writer_guid)); n != per_participant_.end() && --n->second == 0)
    per_participant_.erase(n);
  unindex(writer_guid, id);
  const bool was_shown = std::next(it) == list.end();
  list.erase(it);
  if (list.empty()) {
    remove_device(id, reason, why);
    return true;
  }
  if (was_shown) {  // another server still serves it: show that one
    dev->second.doc.server = list.back().second;
    log::info(prefix() + "device " + id + " now served by writer " + list.back().first + " (" + writer_guid +
              " left: " + why + ")");
    table_.upsert(id, dev->second.doc);
  }
  return false;
}

void DomainBook::participant_gone(const std::string& guid, Clock::time_point now) {
  lost_.participant_gone(guid, now);
  silent_retries_.erase(guid);  // heard again, it is asked again as often as a new one
  std::vector<std::pair<std::string, std::string>> gone;  // device id, writer GUID
  for (const auto& [id, device] : devices_)
    for (const auto& [writer, server] : device.announcers)
      if (participant_of(writer) == guid) gone.emplace_back(id, writer);
  for (const auto& [id, writer] : gone) {
    const auto dev = devices_.find(id);
    if (dev == devices_.end()) continue;
    const auto& list = dev->second.announcers;
    const bool only_this =
        std::all_of(list.begin(), list.end(), [&](const auto& a) { return participant_of(a.first) == guid; });
    if (options_.removal_grace.count() > 0 && only_this) mark_unresponsive(id, now);
    else
      drop_announcer(id, writer, model::RemovalReason::lease_expired,
                     "its participant " + guid + " is gone (left, or its lease expired)");
  }
  // A server that announced cameras and went without 'stopping' (a crash, a cut).
  if (!gone.empty()) lost_.writer_lost(guid, now);
  for (auto it = writers_.begin(); it != writers_.end();)
    it = it->second.identity.participant_guid == guid ? erase_writer(it) : std::next(it);
}

void DomainBook::unindex(const std::string& writer_guid, const std::string& id) {
  if (auto of = devices_of_writer_.find(writer_guid); of != devices_of_writer_.end()) {
    of->second.erase(id);
    if (of->second.empty()) devices_of_writer_.erase(of);
  }
}

void DomainBook::remove_device(const std::string& id, model::RemovalReason reason, const std::string& why) {
  std::string by;  // the server a user knows it by: its name and address, not a GUID
  std::string name;
  std::vector<std::string> addresses;
  if (const auto dev = devices_.find(id); dev != devices_.end()) {
    for (const auto& [writer, server] : dev->second.announcers) unindex(writer, id);
    const model::Server server = dev->second.doc.server.value_or(model::Server{});
    name = server.participant_name.value_or("");
    addresses = server.addresses.value_or(std::vector<std::string>{});
    if (!name.empty() || !addresses.empty())
      by = " (server '" + name + "'" + (addresses.empty() ? "" : " at " + addresses[0]) + ")";
  }
  log::info(prefix() + "device " + id + " removed (" + std::string(model::to_string(reason)) + "): " + why + by);
  const auto event = table_.remove(id, reason, why + by);
  if (event && event->reason == model::RemovalReason::lease_expired && !addresses.empty() &&
      lease_losses_.size() < kMaxLeaseLosses)
    lease_losses_.push_back({event->id, event->generation, name, std::move(addresses)});
  devices_.erase(id);
}

void DomainBook::writer_left(Handle left, const MatchedWriters& still_matched, Clock::time_point now) {
  std::erase_if(refused_, [&](Handle h) { return !still_matched.contains(h); });
  // While reconciling after a fresh reader, writers are still coming back, so
  // only the one that left loses its devices; the sweep comes at the deadline.
  if (!reconcile_at_) {
    sweep(still_matched, nullptr, now);
    return;
  }
  const auto it = writers_.find(left);
  if (it == writers_.end()) return;
  const std::string gone = it->second.identity.guid;
  sweep(still_matched, &gone, now);
}

void DomainBook::writer_gone(Handle left, Clock::time_point now) {
  refused_.erase(left);
  const auto it = writers_.find(left);
  if (it == writers_.end()) return;
  const std::string guid = it->second.identity.guid;
  const std::string participant = it->second.identity.participant_guid;
  erase_writer(it);
  drop_writer_devices(guid, now);
  forget_retries_if_gone(participant);
}

void DomainBook::drop_writer_devices(const std::string& writer_guid, Clock::time_point now) {
  const auto of = devices_of_writer_.find(writer_guid);
  if (of == devices_of_writer_.end()) return;
  const std::set<std::string> ids = of->second;  // drop_announcer changes the index
  for (const auto& id : ids)
    if (!unresponsive_.count(id) &&  // its grace decides
        drop_announcer(id, writer_guid, model::RemovalReason::writer_gone, "its writer " + writer_guid + " is gone"))
      lost_.writer_lost(participant_of(writer_guid), now);  // gone with its writer, not by 'stopping'
}

void DomainBook::forget_retries_if_gone(const std::string& participant_guid) {
  if (writers_of_.count(participant_guid)) return;
  silent_retries_.erase(participant_guid);
  const auto of_it = [&](const std::string& guid) { return participant_of(guid) == participant_guid; };
  std::erase_if(retried_writers_, of_it);
  std::erase_if(idle_writers_, of_it);
}

void DomainBook::sweep(const MatchedWriters& still_matched, const std::string* only, Clock::time_point now,
                       model::RemovalReason reason) {
  std::set<std::string> alive;
  for (auto it = writers_.begin(); it != writers_.end();) {
    if (!still_matched.contains(it->first)) {
      it = erase_writer(it);
    } else {
      alive.insert(it->second.identity.guid);
      ++it;
    }
  }
  std::vector<std::pair<std::string, std::string>> gone;  // device id, writer GUID
  for (const auto& [id, device] : devices_) {
    if (unresponsive_.count(id)) continue;  // its grace decides
    if (device.announcers.empty() && !only) gone.emplace_back(id, std::string());  // its writer was never known
    for (const auto& [writer, server] : device.announcers)
      if (!alive.count(writer) && (!only || writer == *only)) gone.emplace_back(id, writer);
  }
  for (const auto& [id, writer] : gone) {
    if (writer.empty()) {
      remove_device(id, reason, "its writer is gone");
    } else if (drop_announcer(id, writer, reason,
                              reason == model::RemovalReason::interface_gone
                                  ? "not heard again after the host's network changed"
                                  : "its writer " + writer + " is gone")) {
      // A device gone with its writer, not by 'stopping': its server may be lost.
      lost_.writer_lost(participant_of(writer), now);
    }
  }
  // Forget retry counts of servers that have no writer left, or a long-lived
  // daemon would keep one entry for every peer that ever came by.
  std::erase_if(silent_retries_, [&](const auto& entry) { return !writers_of_.count(entry.first); });
  const auto of_a_server_gone = [&](const std::string& guid) { return !writers_of_.count(participant_of(guid)); };
  std::erase_if(retried_writers_, of_a_server_gone);
  std::erase_if(idle_writers_, of_a_server_gone);
}

void DomainBook::reader_made(Clock::time_point now) {
  lost_.reader_made(now);
  writers_.clear();  // handles were per reader; matches come again for the new one
  writers_of_.clear();
  refused_.clear();  // a refused writer may get in now, if there is room
  if (!devices_.empty()) reconcile_at_ = now + options_.reconcile_grace;
  else reconcile_reason_.reset();  // nothing to reconcile: no later one inherits it
}

void DomainBook::participant_made() {
  writers_.clear();
  writers_of_.clear();
  refused_.clear();
  reconcile_at_.reset();  // the reader that follows begins it again
  lost_.participant_rebuilt();
}

DomainBook::Due DomainBook::tick(Clock::time_point now, const MatchedWriters& still_matched) {
  Due due;
  end_graces(now);
  const auto verdict = lost_.check(now);
  for (const auto& guid : verdict.newly_lost)
    log::notice(prefix() + "server " + guid +
                " was lost without saying 'stopping' (crashed, or behind a network cut); looking for it again");
  for (const auto& guid : verdict.given_up) log::info(prefix() + "gave up looking for server " + guid);
  if (verdict.refresh) {
    log::notice(prefix() + "refreshing the DDS participant to find " + std::to_string(lost_.size()) +
                " lost server(s) again; devices are kept");
    due.refresh = true;
    return due;
  }
  if (reconcile_due(now)) {
    reconcile_at_.reset();
    std::erase_if(refused_, [&](Handle h) { return !still_matched.contains(h); });
    sweep(still_matched, nullptr, now, reconcile_reason_.value_or(model::RemovalReason::writer_gone));
    reconcile_reason_.reset();
  }
  due.make_reader_anew = ask_silent_servers_again(now);
  return due;
}

std::optional<DomainBook::Clock::time_point> DomainBook::next_deadline(Clock::time_point now) const {
  std::optional<Clock::time_point> next = lost_.next_check(now);
  // Only what lies ahead: what is due now, tick() has just done or declined.
  const auto consider = [&](Clock::time_point t) {
    if (t > now && (!next || t < *next)) next = t;
  };
  if (reconcile_at_) consider(*reconcile_at_);
  for (const auto& [id, grace] : unresponsive_) consider(grace.until);  // removal graces ending
  for (const auto& [id, held] : in_use_held_) consider(held.until);
  std::optional<std::set<std::string>> awaited;  // worked out only when a writer is silent
  for (const auto& [h, w] : writers_) {
    if (w.sent || idle_writers_.count(w.identity.guid)) continue;
    if (!awaited) awaited = awaited_servers();
    consider(w.matched_at + silent_grace_of(w, *awaited));
  }
  return next;
}

std::map<std::string, PublisherCounts> DomainBook::publishers(Clock::time_point now) const {
  std::map<std::string, PublisherCounts> out;
  for (const auto& [h, w] : writers_) {
    auto& c = out[w.identity.participant_guid];
    ++c.writers;
    if (!w.sent && now - w.matched_at >= options_.silent_grace) ++c.silent;
  }
  for (const auto& [id, device] : devices_) {
    if (!device.doc.topic_root) continue;
    for (const auto& [writer, server] : device.announcers)
      if (auto c = out.find(participant_of(writer)); c != out.end()) c->second.topic_roots.push_back(*device.doc.topic_root);
  }
  for (auto& [guid, c] : out) {
    const auto n = per_participant_.find(guid);
    c.devices = n == per_participant_.end() ? 0 : n->second;
    c.never_announced = c.devices == 0 && c.silent > 0;
  }
  return out;
}

void DomainBook::forget_devices(model::RemovalReason reason) {
  unresponsive_.clear();
  for (const auto& [id, device] : devices_) table_.remove(id, reason);
  devices_.clear();
  per_participant_.clear();
  devices_of_writer_.clear();
}

std::vector<std::string> DomainBook::set_device_caps(std::size_t per_participant, std::size_t per_domain) {
  options_.max_devices_per_participant = per_participant;
  options_.max_devices_per_domain = per_domain;
  std::vector<std::pair<std::uint64_t, std::string>> newest_first;
  for (const auto& [id, device] : devices_) newest_first.emplace_back(device.found, id);
  std::sort(newest_first.rbegin(), newest_first.rend());
  std::vector<std::string> refused;
  for (const auto& [found, id] : newest_first) {
    auto dev = devices_.find(id);
    if (devices_.size() > per_domain) {
      for (const auto& [guid, server] : dev->second.announcers)
        if (auto n = per_participant_.find(participant_of(guid)); n != per_participant_.end() && --n->second == 0)
          per_participant_.erase(n);
      unresponsive_.erase(id);
      remove_device(id, model::RemovalReason::refused,
                    "max-devices-per-domain is now " + std::to_string(per_domain));
      refused.push_back(id);
      continue;
    }
    // Over a participant's cap, that participant's announcement goes; the device
    // stays while another server still announces it.
    const auto announcers = dev->second.announcers;  // drop_announcer edits the list
    for (const auto& [guid, server] : announcers) {
      const auto n = per_participant_.find(participant_of(guid));
      if (n == per_participant_.end() || n->second <= per_participant) continue;
      if (drop_announcer(id, guid, model::RemovalReason::refused,
                         "max-devices-per-participant is now " + std::to_string(per_participant))) {
        unresponsive_.erase(id);
        refused.push_back(id);
        break;
      }
    }
  }
  return refused;
}

void DomainBook::reject(const std::string& reason, const std::string& detail, const std::string& sender) {
  ++rejected_[reason];
  std::uint64_t suppressed = 0;
  if (g_reject_log.allow(std::to_string(options_.domain) + "/" + sender + "/" + reason, suppressed))
    log::warning(prefix() + "dropped a device-info from " + sender + ": " + reason + " (" + detail + ")" +
                 (suppressed ? "; " + std::to_string(suppressed) + " more like it suppressed" : ""));
}

void DomainBook::fill(DomainStatus& s) const {
  s.devices = devices_.size();
  s.accepted = accepted_;
  s.stopping = stopping_;
  s.rejected = rejected_;
  s.lost_servers = lost_.size();
  s.writers = writers_.size();
  s.writers_refused = writers_refused_;
}

}  // namespace rsd::dds
