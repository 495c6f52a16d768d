#include "dds/domain_session.hpp"

#include "dds/flexible_topic.hpp"
#include "log/log.hpp"

#include "flexible.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace rsd::dds {
namespace {

log::RateLimiter g_reject_log;

// realdds gives every participant one writer on device-info that never writes
// (measured: a server with k devices matches k + 1 writers).
constexpr int kIdleWritersPerServer = 1;

std::string dds_error(const char* what, dds_return_t rc) {
  return std::string(what) + ": " + dds_strretcode(rc);
}

std::vector<std::string> split_addresses(const char* value) {
  // Cyclone's "__NetworkAddresses" property: comma-separated locators such as
  // "192.0.2.2:22660@4" or "[fe80::1]:7410@4"; users want the host part.
  std::vector<std::string> out;
  std::string s = value ? value : "";
  std::size_t pos = 0;
  while (pos < s.size()) {
    std::size_t end = s.find(',', pos);
    if (end == std::string::npos) end = s.size();
    std::string item = s.substr(pos, end - pos);
    pos = end + 1;
    if (auto slash = item.find('/'); slash != std::string::npos) item = item.substr(slash + 1);
    item = item.substr(0, item.find('@'));
    if (!item.empty() && item.front() == '[') {
      item = item.substr(1, item.find(']') - 1);
    } else if (std::count(item.begin(), item.end(), ':') == 1) {
      item = item.substr(0, item.find(':'));
    }
    // Cyclone 11 peers list their multicast locators too (239.255.0.1 seen):
    // a group address is not where the camera is.
    const bool multicast = item.starts_with("ff") || (item.find('.') != std::string::npos &&
                                                      std::atoi(item.c_str()) >= 224 && std::atoi(item.c_str()) <= 239);
    if (!item.empty() && !multicast && is_valid_utf8(item) &&
        std::find(out.begin(), out.end(), item) == out.end())
      out.push_back(item);
  }
  return out;
}

// A writer's GUID shares its participant's prefix; the participant's own entity
// id is always 000001c1 (RTPS).
std::string participant_of(const std::string& writer_guid) {
  return writer_guid.size() == 35 ? writer_guid.substr(0, 27) + "000001c1" : writer_guid;
}

}  // namespace

std::string guid_to_string(const dds_guid_t& guid) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%02x%02x%02x%02x.%02x%02x%02x%02x.%02x%02x%02x%02x.%02x%02x%02x%02x",
                guid.v[0], guid.v[1], guid.v[2], guid.v[3], guid.v[4], guid.v[5], guid.v[6], guid.v[7],
                guid.v[8], guid.v[9], guid.v[10], guid.v[11], guid.v[12], guid.v[13], guid.v[14],
                guid.v[15]);
  return buf;
}

DomainSession::DomainSession(SharedTable& table, SessionOptions options)
    : table_(table), options_(std::move(options)), lost_servers_(options_.lost) {}

DomainSession::~DomainSession() { stop(); }

void DomainSession::start() {
  const int d = options_.domain;
  const char* config = options_.cyclone_config.empty() ? nullptr : options_.cyclone_config.c_str();
  domain_ = dds_create_domain(static_cast<dds_domainid_t>(d), config);
  if (domain_ < 0) {
    const std::string why = dds_error(("cannot create DDS domain " + std::to_string(d)).c_str(), domain_);
    domain_ = 0;
    std::lock_guard lock(mutex_);
    state_ = "failed";
    error_ = why + (config ? " (check the cyclonedds configuration)" : "");
    throw std::runtime_error(error_);
  }
  dds_qos_t* qos = dds_create_qos();
  dds_qset_entity_name(qos, options_.participant_name.c_str());
  participant_ = dds_create_participant(static_cast<dds_domainid_t>(d), qos, nullptr);
  dds_delete_qos(qos);
  if (participant_ < 0) {
    const std::string why = dds_error(("cannot join DDS domain " + std::to_string(d)).c_str(), participant_);
    participant_ = 0;
    dds_delete(domain_);
    domain_ = 0;
    std::lock_guard lock(mutex_);
    state_ = "failed";
    error_ = why;
    throw std::runtime_error(why);
  }
  dds_guid_t guid{};
  dds_get_guid(participant_, &guid);
  // Read, never taken: Cyclone keeps each live participant's sample here, so a
  // writer's participant name and addresses can be looked up by instance handle.
  // Its listener also tells which participants are alive, to tell a lost server
  // (participant gone) from one that only dropped a device (participant alive).
  dds_listener_t* participant_listener = dds_create_listener(this);
  dds_lset_data_available(participant_listener, &DomainSession::on_participant_data);
  participant_reader_ =
      dds_create_reader(participant_, DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, nullptr, participant_listener);
  dds_delete_listener(participant_listener);

  dds_qos_t* tqos = dds_create_qos();
  dds_qset_reliability(tqos, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
  dds_qset_durability(tqos, DDS_DURABILITY_VOLATILE);
  topic_ = create_flexible_topic(participant_, kDeviceInfoTopic, tqos);
  dds_delete_qos(tqos);
  if (topic_ < 0) {
    const std::string why = dds_error("cannot create topic realsense/device-info", topic_);
    topic_ = 0;
    stop();
    std::lock_guard lock(mutex_);
    state_ = "failed";
    error_ = why;
    throw std::runtime_error(why);
  }
  joined_at_ = Clock::now();
  std::lock_guard lock(mutex_);
  participant_guid_ = guid_to_string(guid);
  state_ = "settling";
  error_.clear();
  log::info("domain " + std::to_string(d) + ": joined as participant " + participant_guid_ +
            "; reading device-info after " + std::to_string(options_.settle.count()) + " ms of discovery");
}

void DomainSession::stop() {
  delete_reader();
  if (domain_ > 0) dds_delete(domain_);  // takes the participant, topic and builtin reader with it
  else if (participant_ > 0) dds_delete(participant_);
  domain_ = participant_ = topic_ = participant_reader_ = 0;
  std::lock_guard lock(mutex_);
  state_ = "stopped";
  participant_guid_.clear();
  writers_.clear();
  lost_servers_.participant_rebuilt();  // the next participant hears them anew
  reconcile_at_.reset();
}

void DomainSession::rebuild() {
  log::notice("domain " + std::to_string(options_.domain) +
              ": rebuilding the DDS participant; devices are kept until reconciled");
  stop();
  {
    std::lock_guard lock(mutex_);
    ++rebuilds_;
  }
  start();  // the reader follows after the settle time, then reconciliation
}

void DomainSession::forget_devices() {
  std::lock_guard lock(mutex_);
  for (const auto& [id, device] : devices_) table_.remove(id);
  devices_.clear();
  devices_per_participant_.clear();
}

bool DomainSession::reading() const { return reader_ > 0; }

void DomainSession::create_reader() {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  // realdds' own readers keep the last 10, but the topic has no key, so every
  // writer's samples share one instance: a server announcing many devices at
  // once overflows that before the listener takes them (42 of 100 seen). History
  // is not matched against writers, so the daemon keeps more (reader_history),
  // but not all: a flooding writer once queued 150,000 samples here.
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, options_.reader_history);
  dds_listener_t* listener = dds_create_listener(this);
  dds_lset_data_available(listener, &DomainSession::on_data_available);
  dds_lset_subscription_matched(listener, &DomainSession::on_subscription_matched);
  const dds_entity_t reader = dds_create_reader(participant_, topic_, qos, listener);
  dds_delete_listener(listener);
  dds_delete_qos(qos);
  if (reader < 0) {
    std::lock_guard lock(mutex_);
    state_ = "failed";
    error_ = dds_error("cannot create the device-info reader", reader);
    log::error("domain " + std::to_string(options_.domain) + ": " + error_);
    return;
  }
  reader_ = reader;
  std::lock_guard lock(mutex_);
  state_ = "running";
  if (!first_reader_at_) first_reader_at_ = Clock::now();
}

void DomainSession::delete_reader() {
  if (reader_ <= 0) return;
  const dds_entity_t reader = reader_;
  reader_ = 0;
  dds_set_listener(reader, nullptr);
  dds_delete(reader);
  std::lock_guard lock(mutex_);
  writers_.clear();  // handles were per reader; matches come again for the next one
}

void DomainSession::begin_reconcile(Clock::time_point now) {
  std::lock_guard lock(mutex_);
  if (!devices_.empty()) reconcile_at_ = now + options_.reconcile_grace;
}

DomainSession::Clock::duration DomainSession::tick(Clock::time_point now) {
  using namespace std::chrono;
  if (participant_ <= 0) return seconds(1);
  if (reader_ <= 0) {
    if (now - joined_at_ < options_.settle) return options_.settle - (now - joined_at_);
    create_reader();
    begin_reconcile(now);
    return milliseconds(250);
  }

  bool recreate = false;
  bool refresh = false;
  {
    std::lock_guard lock(mutex_);
    const auto verdict = lost_servers_.check(now);
    const std::string d = "domain " + std::to_string(options_.domain) + ": ";
    for (const auto& guid : verdict.newly_lost)
      log::notice(d + "server " + guid +
                  " was lost without saying 'stopping' (crashed, or behind a network cut); looking for it again");
    for (const auto& guid : verdict.given_up) log::info(d + "gave up looking for server " + guid);
    if (verdict.refresh)
      log::notice(d + "refreshing the DDS participant to find " + std::to_string(lost_servers_.size()) +
                  " lost server(s) again; devices are kept");
    refresh = verdict.refresh;
    if (reconcile_at_ && now >= *reconcile_at_) {
      reconcile_at_.reset();
      drop_devices_without_writer(reader_, nullptr);
    }
    // Count, per server, the writers that matched a while ago and sent nothing.
    std::map<std::string, int> silent;  // participant GUID -> such writers
    for (const auto& [h, w] : writers_)
      if (!w.sent && now - w.matched_at >= options_.silent_grace) ++silent[w.participant_guid];
    for (const auto& [p, count] : silent) {
      Server& server = servers_[p];
      if (count < kIdleWritersPerServer + 1 || server.silent_retries >= options_.silent_retries) continue;
      ++server.silent_retries;
      log::info("domain " + std::to_string(options_.domain) + ": server " + p + " has " +
                std::to_string(count - kIdleWritersPerServer) +
                " device writer(s) that matched but sent no device-info; making the reader anew so "
                "it broadcasts again (try " + std::to_string(server.silent_retries) + ")");
      recreate = true;
    }
  }
  if (refresh) {
    {
      std::lock_guard lock(mutex_);
      ++refreshes_;
    }
    rebuild();  // the reader follows after the settle time
    return options_.settle;
  }
  if (recreate) {
    delete_reader();
    create_reader();
    begin_reconcile(now);
  }
  return milliseconds(250);
}

// Cyclone calls these from its own (C) threads: an exception must not cross
// back into it, so whatever slipped through is logged and the sample dropped.
void DomainSession::on_data_available(dds_entity_t reader, void* arg) {
  try {
    static_cast<DomainSession*>(arg)->take_samples(reader);
  } catch (const std::exception& e) {
    log::error(std::string("device-info listener: ") + e.what());
  }
}

void DomainSession::on_participant_data(dds_entity_t reader, void* arg) {
  try {
    static_cast<DomainSession*>(arg)->take_participant_changes(reader);
  } catch (const std::exception& e) {
    log::error(std::string("participant listener: ") + e.what());
  }
}

void DomainSession::take_participant_changes(dds_entity_t reader) {
  // Only samples not read before: each is a participant appearing or leaving.
  // They are read, not taken, so writer_for() can still look names up.
  constexpr std::size_t kBatch = 16;
  std::array<void*, kBatch> samples{};
  std::array<dds_sample_info_t, kBatch> infos{};
  for (;;) {
    samples.fill(nullptr);
    const dds_return_t n = dds_read_mask(reader, samples.data(), infos.data(), kBatch, kBatch,
                                         DDS_NOT_READ_SAMPLE_STATE | DDS_ANY_VIEW_STATE | DDS_ANY_INSTANCE_STATE);
    if (n <= 0) break;
    {
      std::lock_guard lock(mutex_);
      for (dds_return_t i = 0; i < n; ++i) {
        const auto* p = static_cast<const dds_builtintopic_participant_t*>(samples[static_cast<std::size_t>(i)]);
        const std::string guid = guid_to_string(p->key);
        if (infos[static_cast<std::size_t>(i)].instance_state == DDS_IST_ALIVE) lost_servers_.participant_alive(guid);
        else lost_servers_.participant_gone(guid);
      }
    }
    dds_return_loan(reader, samples.data(), n);
    if (static_cast<std::size_t>(n) < kBatch) break;
  }
}

void DomainSession::on_subscription_matched(dds_entity_t reader,
                                            dds_subscription_matched_status_t status, void* arg) {
  try {
    static_cast<DomainSession*>(arg)->handle_matched(reader, status);
  } catch (const std::exception& e) {
    log::error(std::string("subscription-matched listener: ") + e.what());
  }
}

void DomainSession::take_samples(dds_entity_t reader) {
  constexpr std::size_t kBatch = 16;
  std::array<void*, kBatch> samples{};
  std::array<dds_sample_info_t, kBatch> infos{};
  for (;;) {
    samples.fill(nullptr);
    const dds_return_t n = dds_take(reader, samples.data(), infos.data(), kBatch, kBatch);
    if (n <= 0) break;
    for (dds_return_t i = 0; i < n; ++i) {
      const auto& info = infos[static_cast<std::size_t>(i)];
      if (!info.valid_data) continue;  // a writer's unregister/dispose: matching tells us that
      const auto* msg = static_cast<const realdds_topics_raw_flexible*>(samples[static_cast<std::size_t>(i)]);
      try {  // one bad sample must not keep the loan or the rest of the batch
        handle_sample(reader, info.publication_handle, static_cast<std::int32_t>(msg->data_format),
                      std::span<const std::uint8_t>(msg->data._buffer, msg->data._length));
      } catch (const std::exception& e) {
        log::error(std::string("device-info sample dropped: ") + e.what());
      }
    }
    dds_return_loan(reader, samples.data(), n);
    if (static_cast<std::size_t>(n) < kBatch) break;
  }
}

DomainSession::Writer* DomainSession::writer_for(dds_entity_t reader, dds_instance_handle_t publication) {
  if (auto it = writers_.find(publication); it != writers_.end()) return &it->second;
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, publication);
  if (!ep) return nullptr;  // unmatched meanwhile
  Writer w;
  w.guid = guid_to_string(ep->key);
  w.participant_guid = guid_to_string(ep->participant_key);
  w.matched_at = Clock::now();
  const dds_instance_handle_t participant_handle = ep->participant_instance_handle;
  dds_builtintopic_free_endpoint(ep);

  Server& server = servers_[w.participant_guid];
  if (participant_reader_ > 0) {
    void* sample = nullptr;
    dds_sample_info_t info{};
    if (dds_read_instance(participant_reader_, &sample, &info, 1, 1, participant_handle) > 0) {
      const auto* p = static_cast<const dds_builtintopic_participant_t*>(sample);
      char* name = nullptr;
      if (p->qos && dds_qget_entity_name(p->qos, &name) && name) {
        server.name = is_valid_utf8(name) ? name : "";
        dds_free(name);
      }
      char* addresses = nullptr;
      if (p->qos && dds_qget_prop(p->qos, "__NetworkAddresses", &addresses) && addresses) {
        server.addresses = split_addresses(addresses);
        dds_free(addresses);
      }
      dds_return_loan(participant_reader_, &sample, 1);
    }
  }
  log::debug("domain " + std::to_string(options_.domain) + ": writer " + w.guid + " of " +
             w.participant_guid + " (" + server.name + ") matched");
  return &writers_.emplace(publication, std::move(w)).first->second;
}

void DomainSession::handle_sample(dds_entity_t reader, dds_instance_handle_t publication,
                                  std::int32_t format, std::span<const std::uint8_t> data) {
  Parsed parsed = parse_device_info(format, data);
  std::lock_guard lock(mutex_);
  Writer* writer = writer_for(reader, publication);
  const std::string sender = writer ? writer->guid : "unknown writer";
  if (writer) writer->sent = true;

  if (auto* bad = std::get_if<Rejected>(&parsed)) {
    reject(bad->reason, bad->detail, sender);
    return;
  }
  if (auto* stop = std::get_if<Stopping>(&parsed)) {
    ++stopping_;
    const std::string id = device_id(options_.domain, stop->topic_root);
    log::info("domain " + std::to_string(options_.domain) + ": " + stop->topic_root +
              " is stopping (from " + sender + ")");
    // From a writer that never announced it (or an unknown one): the device
    // goes all the same, as realdds itself does with any 'stopping'.
    auto it = devices_.find(id);
    if (it == devices_.end()) return;
    const bool announced_by_sender =
        writer && std::any_of(it->second.announcers.begin(), it->second.announcers.end(),
                              [&](const auto& a) { return a.first == writer->guid; });
    if (announced_by_sender) {
      drop_announcer(id, writer->guid, "its server is stopping");
    } else {
      while (!it->second.announcers.empty() &&
             !drop_announcer(id, it->second.announcers.back().first, "a server says it is stopping")) {
      }
    }
    return;
  }
  auto& info = std::get<DeviceInfo>(parsed);
  const std::string id = device_id(options_.domain, info.topic_root);
  const std::string participant = writer ? writer->participant_guid : std::string();
  if (!devices_.count(id)) {
    if (devices_.size() >= options_.max_devices_per_domain) {
      reject("domain-device-limit", "the domain has " + std::to_string(devices_.size()) + " devices already",
             sender);
      return;
    }
    if (!participant.empty() && devices_per_participant_[participant] >= options_.max_devices_per_participant) {
      reject("participant-device-limit",
             "its participant announces " + std::to_string(devices_per_participant_[participant]) +
                 " devices already",
             sender);
      return;
    }
  }
  nlohmann::json doc = std::move(info.fields);
  const auto recovery = doc.find("recovery");
  const bool in_recovery = recovery != doc.end() && recovery->is_boolean() && recovery->get<bool>();
  doc["source"] = "dds";
  doc["domain"] = options_.domain;
  doc["topic-root"] = info.topic_root;
  doc["recovery"] = in_recovery;
  nlohmann::json server = nlohmann::json::object();
  if (writer) {
    const Server& s = servers_[writer->participant_guid];
    server["participant-guid"] = writer->participant_guid;
    server["participant-name"] = s.name;
    server["addresses"] = s.addresses;
    server["writer-guid"] = writer->guid;
    lost_servers_.announced(writer->participant_guid);  // found again, if it was lost
  }
  doc["server"] = server;
  Announced& device = devices_[id];
  if (writer) add_announcer(device, writer->guid, std::move(server));
  device.doc = doc;
  ++accepted_;
  if (auto ev = table_.upsert(id, std::move(doc)); ev && ev->type == EventType::added)
    log::info("domain " + std::to_string(options_.domain) + ": device " + id + " added (from " + sender + ")");
}

void DomainSession::add_announcer(Announced& device, const std::string& writer_guid, nlohmann::json server) {
  auto& list = device.announcers;
  const auto it = std::find_if(list.begin(), list.end(), [&](const auto& a) { return a.first == writer_guid; });
  if (it != list.end()) list.erase(it);
  else ++devices_per_participant_[participant_of(writer_guid)];
  list.emplace_back(writer_guid, std::move(server));  // the latest announcer is shown
}

bool DomainSession::drop_announcer(const std::string& id, const std::string& writer_guid, const std::string& why) {
  auto dev = devices_.find(id);
  if (dev == devices_.end()) return true;
  auto& list = dev->second.announcers;
  const auto it = std::find_if(list.begin(), list.end(), [&](const auto& a) { return a.first == writer_guid; });
  if (it != list.end()) {
    const std::string participant = participant_of(writer_guid);
    if (auto count = devices_per_participant_.find(participant);
        count != devices_per_participant_.end() && --count->second == 0)
      devices_per_participant_.erase(count);
    const bool was_shown = std::next(it) == list.end();
    list.erase(it);
    if (!list.empty()) {
      if (was_shown) {  // another server still serves it: show that one
        dev->second.doc["server"] = list.back().second;
        log::info("domain " + std::to_string(options_.domain) + ": device " + id + " now served by writer " +
                  list.back().first + " (" + writer_guid + " left: " + why + ")");
        table_.upsert(id, dev->second.doc);
      }
      return false;
    }
  }
  log::info("domain " + std::to_string(options_.domain) + ": device " + id + " removed: " + why);
  table_.remove(id);
  devices_.erase(dev);
  return true;
}

void DomainSession::handle_matched(dds_entity_t reader, const dds_subscription_matched_status_t& status) {
  std::lock_guard lock(mutex_);
  if (status.current_count_change > 0) {
    writer_for(reader, status.last_publication_handle);
    return;
  }
  if (status.current_count_change >= 0) return;
  // While reconciling after a fresh reader, writers are still coming back, so
  // only the one that left loses its devices; the sweep comes at the deadline.
  std::string gone;
  if (auto it = writers_.find(status.last_publication_handle); it != writers_.end()) gone = it->second.guid;
  if (reconcile_at_) {
    if (!gone.empty()) drop_devices_without_writer(reader, &gone);
  } else {
    drop_devices_without_writer(reader, nullptr);
  }
}

void DomainSession::drop_devices_without_writer(dds_entity_t reader, const std::string* only_writer) {
  // The status of one callback names one writer, yet several can leave at once
  // (a whole server): ask Cyclone which writers are still matched.
  std::set<std::string> alive;
  std::array<dds_instance_handle_t, 1024> handles{};
  const dds_return_t n = reader > 0 ? dds_get_matched_publications(reader, handles.data(), handles.size()) : 0;
  std::set<dds_instance_handle_t> matched(handles.begin(), handles.begin() + std::max<dds_return_t>(n, 0));
  for (auto it = writers_.begin(); it != writers_.end();) {
    if (!matched.count(it->first)) it = writers_.erase(it);
    else {
      alive.insert(it->second.guid);
      ++it;
    }
  }
  const auto now = Clock::now();
  std::vector<std::pair<std::string, std::string>> gone;  // device id, writer GUID
  for (const auto& [id, device] : devices_)
    for (const auto& [writer, server] : device.announcers)
      if (!alive.count(writer) && (!only_writer || writer == *only_writer)) gone.emplace_back(id, writer);
  for (const auto& [id, writer] : gone) {
    if (drop_announcer(id, writer, "its writer " + writer + " is gone")) {
      // A device gone with its writer, not by 'stopping': its server may be lost.
      const std::string participant = participant_of(writer);
      lost_servers_.writer_lost(participant, now);
    }
  }
  // Forget servers that have no writer left, or a long-lived daemon would keep
  // one entry for every peer that ever came by.
  std::set<std::string> with_writers;
  for (const auto& [h, w] : writers_) with_writers.insert(w.participant_guid);
  std::erase_if(servers_, [&](const auto& entry) { return !with_writers.count(entry.first); });
}

void DomainSession::reject(const std::string& reason, const std::string& detail, const std::string& sender) {
  ++rejected_[reason];
  std::uint64_t suppressed = 0;
  if (g_reject_log.allow(std::to_string(options_.domain) + "/" + sender + "/" + reason, suppressed))
    log::warning("domain " + std::to_string(options_.domain) + ": dropped a device-info from " + sender +
                 ": " + reason + " (" + detail + ")" +
                 (suppressed ? "; " + std::to_string(suppressed) + " more like it suppressed" : ""));
}

DomainStatus DomainSession::status() const {
  std::lock_guard lock(mutex_);
  DomainStatus s;
  s.domain = options_.domain;
  s.state = state_;
  s.participant_guid = participant_guid_;
  s.error = error_;
  s.devices = devices_.size();
  s.accepted = accepted_;
  s.stopping = stopping_;
  s.rejected = rejected_;
  s.rebuilds = rebuilds_;
  s.refreshes = refreshes_;
  s.lost_servers = lost_servers_.size();
  s.complete = state_ == "failed" ||
               (first_reader_at_ && Clock::now() - *first_reader_at_ >= options_.initial_grace);
  return s;
}

}  // namespace rsd::dds
