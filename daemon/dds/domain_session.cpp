// DomainSession's lifecycle (join, leave, rebuild, follow the network), its timers,
// and the realsense/device-info reader that feeds the DomainBook. Who is on the
// domain (the built-in topics) is domain_participants.cpp; shared USB cameras are
// ShareSession's.
#include "dds/domain_session.hpp"

#include "dds/builtin_topics.hpp"
#include "dds/cyclone_defaults.hpp"

#include "dds/flexible_topic.hpp"
#include "dds/ros_nodes.hpp"
#include "dds/take_batches.hpp"
#include "log/log.hpp"

#include "flexible.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace rsd::dds {
namespace {

std::string dds_error(const char* what, dds_return_t rc) {
  return std::string(what) + ": " + dds_strretcode(rc);
}

}  // namespace

std::string guid_to_string(const dds_guid_t& guid) { return guid_text(std::span<const unsigned char, 16>(guid.v)); }

DomainSession::DomainSession(SharedTable& table, SessionOptions options)
    : options_(std::move(options)), book_(table, [this] {
        BookOptions book = options_.book;
        book.domain = options_.domain;
        return book;
      }()),
      fetcher_(options_.domain, options_.describe_timeout,
               [this, &table](const std::string& topic_root, const Readiness& r) {
                 if (r.ready) table.note_described(device_id(options_.domain, topic_root));  // the `described` event
                 {
                   std::lock_guard lock(mutex_);
                   book_.set_readiness(topic_root, r.ready, r.stage);
                 }
                 if (options_.wake) options_.wake();  // its reader goes on the main thread
               }),
      share_(table, [this] {
        ShareOptions share = options_.share;
        share.book.domain = options_.domain;
        return share;
      }()),
      host_checks_(table, options_.domain) {}

DomainSession::~DomainSession() { stop(); }

void DomainSession::start() {
  const int d = options_.domain;
  // The user's Cyclone configuration (the daemon's option, else CYCLONEDDS_URI)
  // comes after the daemon's own defaults, so it overrides them.
  std::string user_config = options_.cyclone_config;
  if (const char* uri = std::getenv("CYCLONEDDS_URI"); user_config.empty() && uri) user_config = uri;
  std::string config = kCycloneDefaults;
  if (!options_.interfaces_from_cyclone_config && !options_.interfaces.empty())
    config += "," + net::cyclone_interfaces_xml(options_.interfaces);
  if (!user_config.empty()) config += "," + user_config;
  domain_ = dds_create_domain(static_cast<dds_domainid_t>(d), config.c_str());
  if (domain_ < 0) {
    const std::string why = dds_error(("cannot create DDS domain " + std::to_string(d)).c_str(), domain_);
    domain_ = 0;
    std::lock_guard lock(mutex_);
    state_ = DomainState::failed;
    error_ = why + (user_config.empty() ? "" : " (check the cyclonedds configuration)");
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
    state_ = DomainState::failed;
    error_ = why;
    throw std::runtime_error(why);
  }
  dds_guid_t guid{};
  dds_get_guid(participant_, &guid);
  {
    // Known before the participant reader exists: its listener runs at once and
    // leaves the daemon's own participant out of /v1/participants by it.
    std::lock_guard lock(mutex_);
    participant_guid_ = guid_to_string(guid);
  }
  create_builtin_readers();
  // Shared USB cameras: a failure costs sharing, not the domain.
  if (const std::string why = share_.start(participant_, guid_to_string(guid), Clock::now()); !why.empty())
    log::warning(log::domain_prefix(d) + why);
  share_usb(std::move(usb_cameras_));  // a new writer has announced nothing yet

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
    state_ = DomainState::failed;
    error_ = why;
    throw std::runtime_error(why);
  }
  joined_at_ = Clock::now();
  fetcher_.set_participant(participant_);
  std::lock_guard lock(mutex_);
  // A participant made anew keeps the domain's devices meanwhile: "rebuilding"
  // says so until its reader reads again; a first join is "settling".
  state_ = rebuilding_ ? DomainState::rebuilding : DomainState::settling;
  error_.clear();
  log::info(log::domain_prefix(d) + "joined as participant " + participant_guid_ +
            "; reading device-info after " + std::to_string(options_.settle.count()) +
            " ms of discovery, or once the servers it waits for are heard");
}

void DomainSession::stop() {
  fetcher_.set_participant(0);  // fetches end, their readers go before the participant
  delete_reader();
  // Leaving for good, other hosts see this host's cameras go now (not at lease
  // expiry); a rebuild hands them to the next participant's writer.
  share_.stop(!rebuilding_);
  if (domain_ > 0) dds_delete(domain_);  // takes the participant, topic and builtin reader with it
  else if (participant_ > 0) dds_delete(participant_);
  domain_ = participant_ = topic_ = participant_reader_ = 0;
  std::lock_guard lock(mutex_);
  state_ = DomainState::stopped;
  participant_guid_.clear();
  book_.participant_made();  // the next participant hears everyone anew
  participants_.participant_rebuilt();
  // Kept devices lose their clients with the endpoints forgotten: a client gone
  // meanwhile never comes back to say so; those still there are heard again.
  update_in_use(book_.topic_roots());
}

void DomainSession::rebuild() {
  log::notice(log::domain_prefix(options_.domain) +
              "rebuilding the DDS participant; devices are kept until reconciled");
  rebuilding_ = true;
  stop();
  {
    std::lock_guard lock(mutex_);
    ++rebuilds_;
  }
  try {
    start();  // the reader follows after the settle time, then reconciliation
  } catch (...) {
    rebuilding_ = false;
    throw;
  }
  rebuilding_ = false;
}

void DomainSession::follow_network(std::vector<net::NetInterface> chosen) {
  {
    std::lock_guard lock(mutex_);  // status() reads them on API threads
    options_.interfaces = std::move(chosen);
    ++network_changes_;
    book_.network_changed();
    network_changed_at_ = SharedTable::now_iso8601();
  }
  rebuild();
}

void DomainSession::forget_devices(model::RemovalReason reason) {
  {
    std::lock_guard lock(mutex_);
    book_.forget_devices(reason);
  }
  share_.forget_devices(reason);
}

void DomainSession::set_device_caps(std::size_t per_participant, std::size_t per_domain) {
  std::lock_guard lock(mutex_);
  options_.book.max_devices_per_participant = per_participant;
  options_.book.max_devices_per_domain = per_domain;
  book_.set_device_caps(per_participant, per_domain);
}

void DomainSession::share_usb(std::map<std::string, nlohmann::json> cameras) {
  // Where other hosts reach this one: the addresses the domain is joined on
  // (only the main thread changes them).
  std::vector<std::string> addresses;
  if (!options_.interfaces_from_cyclone_config)
    for (const auto& i : options_.interfaces)
      for (const auto& a : i.ipv4)
        if (addresses.size() < kMaxSharedAddresses) addresses.push_back(a);
  usb_cameras_ = std::move(cameras);
  share_.publish(usb_cameras_, addresses);
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
  // but not all: a flooding writer once queued 150,000 samples here. A site that
  // raises the domain's device cap gets a history as deep: 2,500 raw writers of one
  // domain announcing at once (bench scale10k) must not overwrite each other.
  const auto cap = static_cast<int>(std::min<std::size_t>(options_.book.max_devices_per_domain, 1 << 20));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, std::max(options_.reader_history, cap));
  dds_listener_t* listener = dds_create_listener(this);
  dds_lset_data_available(listener, &DomainSession::on_data_available);
  dds_lset_subscription_matched(listener, &DomainSession::on_subscription_matched);
  // The book first: Cyclone matches known writers inside dds_create_reader (listener).
  const auto now = Clock::now();
  std::unique_lock book_lock(mutex_);
  book_.reader_made(now);
  book_lock.unlock();  // the listener takes it
  const dds_entity_t reader = dds_create_reader(participant_, topic_, qos, listener);
  dds_delete_listener(listener);
  dds_delete_qos(qos);
  if (reader < 0) {
    std::lock_guard lock(mutex_);
    state_ = DomainState::failed;
    error_ = dds_error("cannot create the device-info reader", reader);
    log::error(log::domain_prefix(options_.domain) + error_);
    return;
  }
  reader_ = reader;
  std::lock_guard lock(mutex_);
  state_ = DomainState::running;
  if (!first_reader_at_) first_reader_at_ = now;
}

void DomainSession::delete_reader() {
  if (reader_ <= 0) return;
  const dds_entity_t reader = reader_;
  reader_ = 0;
  dds_set_listener(reader, nullptr);
  dds_delete(reader);
}

MatchedWriters DomainSession::matched_writers(dds_entity_t reader) const {
  // dds_get_matched_publications returns how many writers are matched, not how
  // many it stored (it stores at most the array's size: Cyclone 0.10.2's
  // dds_matched.c counts on past the end). So the array grows to the count and
  // is asked again; writers may match between the two calls, hence the loop.
  // A fixed array here once built the set from past its end (a crash with one
  // writer more than the array held).
  std::vector<dds_instance_handle_t> handles(64);
  for (;;) {
    const dds_return_t n = reader > 0 ? dds_get_matched_publications(reader, handles.data(), handles.size()) : 0;
    if (n < 0) return {};  // the reader is gone: nothing is matched to it
    if (static_cast<std::size_t>(n) <= handles.size()) {
      handles.resize(static_cast<std::size_t>(n));
      return MatchedWriters(std::move(handles));
    }
    handles.resize(static_cast<std::size_t>(n) + static_cast<std::size_t>(n) / 4);  // room for a few more
  }
}

bool DomainSession::servers_heard() const {
  // The settle time is a guess at when Cyclone knows the servers' writers; after
  // a rebuild the daemon knows which servers it waits for, and the new participant
  // says when it knows their writers. On a lossy link that is what keeps a camera
  // heard again from waiting the whole settle time on top of its refresh.
  std::lock_guard lock(mutex_);
  const auto servers = book_.servers_to_hear();
  return !servers.empty() && std::all_of(servers.begin(), servers.end(), [&](const std::string& p) {
    return participants_.endpoints().writes(p, kDeviceInfoTopic);
  });
}

DomainSession::Clock::duration DomainSession::tick(Clock::time_point now) {
  using namespace std::chrono;
  if (participant_ <= 0) return kIdle;  // nothing joined: a reload or rebuild starts it anew
  Clock::duration wait = std::min(kIdle, share_.tick(now));
  std::optional<Clock::time_point> held;  // in-use summaries held (a client leaving): before the reader too
  { std::lock_guard lock(mutex_); held = book_.flush_in_use(now); }
  if (held) wait = std::min(wait, *held - now);
  if (reader_ <= 0) {
    const bool heard = servers_heard();
    std::unique_lock lock(mutex_);
    const auto settle = book_.lost_servers() ? std::max(options_.settle, options_.settle_for_lost) : options_.settle;
    lock.unlock();
    if (now - joined_at_ < settle && !heard) return std::min(wait, settle - (now - joined_at_));
    log::info(log::domain_prefix(options_.domain) + "reading device-info " +
              std::to_string(duration_cast<milliseconds>(now - joined_at_).count()) + " ms after joining" +
              (heard ? " (every server it waits for is heard)" : ""));
    create_reader();
  }

  // Listed only when the book reconciles: with thousands of writers, listing
  // and sorting them at every turn of the loop would be most of an idle daemon's CPU.
  bool reconciling = false;
  {
    std::lock_guard lock(mutex_);
    reconciling = book_.reconcile_due(now);
  }
  const MatchedWriters matched = reconciling ? matched_writers(reader_) : MatchedWriters{};
  DomainBook::Due due;
  std::vector<LeaseLoss> lease_losses;
  std::set<std::string> present;                 // topic-roots in the table now
  std::map<std::string, nlohmann::json> eager;  // topic-root -> announcement, to describe
  std::optional<Clock::time_point> book_next;
  {
    std::lock_guard lock(mutex_);
    // reconcile_due(now) holds as above: only this (the main) thread moves the
    // book's reconcile deadline.
    due = book_.tick(now, matched);
    if (due.refresh) ++refreshes_;
    lease_losses = book_.take_lease_losses();
    present = book_.topic_roots();
    // Copied only where asked for: with 100 devices, copying every announcement at
    // each turn was most of what an idle daemon spent.
    if (options_.describe_eagerly && !due.refresh) eager = book_.announcements();
    book_next = book_.next_deadline(now);
  }
  fetcher_.tick(now, [&](const std::string& topic_root) { return present.count(topic_root) > 0; });
  host_checks_.add(std::move(lease_losses), now);
  if (const auto probe_next = host_checks_.poll(now)) wait = std::min(wait, *probe_next);
  for (const auto& [topic_root, announcement] : eager)
    if (!announcement.value("recovery", false)) fetcher_.prefetch(topic_root, announcement);
  if (due.refresh) {
    rebuild();  // the reader follows after the settle time
    return std::min(wait, Clock::duration(options_.settle));
  }
  if (due.make_reader_anew) {
    delete_reader();
    create_reader();
    std::lock_guard lock(mutex_);
    book_next = book_.next_deadline(now);  // the new reader set a reconciliation
  }
  if (book_next) wait = std::min(wait, *book_next - now);
  if (const auto fetch_next = fetcher_.next_deadline(now)) wait = std::min(wait, *fetch_next - now);
  return wait;
}

// Cyclone calls these from its own (C) threads: an exception must not cross
// back into it, so whatever slipped through is logged and the sample dropped.
void DomainSession::on_data_available(dds_entity_t reader, void* arg) {
  try {
    auto* self = static_cast<DomainSession*>(arg);
    self->take_samples(reader);
    if (self->options_.describe_eagerly) self->wake();  // its new devices are described from tick()
  } catch (const std::exception& e) {
    log::error(std::string("device-info listener: ") + e.what());
  }
}

void DomainSession::on_subscription_matched(dds_entity_t reader,
                                            dds_subscription_matched_status_t status, void* arg) {
  try {
    auto* self = static_cast<DomainSession*>(arg);
    self->handle_matched(reader, status);
    self->wake();  // a writer's silence, or a lost server, is timed from now
  } catch (const std::exception& e) {
    log::error(std::string("subscription-matched listener: ") + e.what());
  }
}

void DomainSession::take_samples(dds_entity_t reader) {
  take_batches(reader, [&](std::span<void* const> samples, std::span<const dds_sample_info_t> infos) {
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const auto& info = infos[i];
      if (!info.valid_data) continue;  // a writer's unregister/dispose: matching tells us that
      const auto* msg = static_cast<const realdds_topics_raw_flexible*>(samples[i]);
      try {  // one bad sample must not keep the loan or the rest of the batch
        Parsed parsed = parse_device_info(static_cast<std::int32_t>(msg->data_format),
                                          std::span<const std::uint8_t>(msg->data._buffer, msg->data._length));
        const auto* device = std::get_if<DeviceInfo>(&parsed);
        std::string root = device ? device->topic_root : std::string();
        std::lock_guard lock(mutex_);
        identify(reader, info.publication_handle);
        book_.sample(info.publication_handle, std::move(parsed));
        // Its clients may have come first, counted for a camera its root extends.
        if (!root.empty()) update_in_use(realdds_topics::root_and_prefixes(root));
      } catch (const std::exception& e) {
        log::error(std::string("device-info sample dropped: ") + e.what());
      }
    }
  });
}

void DomainSession::identify(dds_entity_t reader, dds_instance_handle_t publication) {
  if (book_.knows(publication)) return;
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, publication);
  if (!ep) return;  // unmatched meanwhile: an unknown sender
  WriterIdentity w;
  w.guid = guid_to_string(ep->key);
  w.participant_guid = guid_to_string(ep->participant_key);
  const dds_instance_handle_t participant_handle = ep->participant_instance_handle;
  dds_builtintopic_free_endpoint(ep);
  if (participant_reader_ > 0) {
    if (auto p = read_participant(participant_reader_, participant_handle)) {
      w.participant_name = std::move(p->name);
      w.addresses = std::move(p->addresses);
    }
  }
  book_.writer_matched(publication, std::move(w), Clock::now());
}

void DomainSession::handle_matched(dds_entity_t reader, const dds_subscription_matched_status_t& status) {
  if (status.current_count_change > 0) {
    std::lock_guard lock(mutex_);
    identify(reader, status.last_publication_handle);
    return;
  }
  if (status.current_count_change >= 0) return;
  // The status counts changes since the last call: one writer left and none
  // came, so the one it names is all that changed. Listing every matched writer
  // for each departure instead made a server of thousands of writers leaving
  // cost thousands times thousands.
  if (status.current_count_change == -1 && status.total_count_change == 0) {
    std::lock_guard lock(mutex_);
    book_.writer_gone(status.last_publication_handle, Clock::now());
    return;
  }
  const auto matched = matched_writers(reader);
  std::lock_guard lock(mutex_);
  book_.writer_left(status.last_publication_handle, matched, Clock::now());
}

std::optional<DescribeResult> DomainSession::describe(const std::string& topic_root, std::chrono::milliseconds wait) {
  std::optional<nlohmann::json> announcement;
  {
    std::lock_guard lock(mutex_);
    announcement = book_.announcement(topic_root);
  }
  if (!announcement) return std::nullopt;
  // first-seen/last-seen are the table's, not part of it; what the server
  // announced (and which server) decides whether a kept description still holds.
  return fetcher_.describe(topic_root, *announcement, wait);
}

DomainStatus DomainSession::status() const {
  DomainStatus shared;
  share_.fill(shared);  // before mutex_: the share's lock is never taken under it
  DomainStatus s;
  std::lock_guard lock(mutex_);
  s.domain = options_.domain;
  s.state = state_;
  s.participant_guid = participant_guid_;
  s.error = error_;
  book_.fill(s);
  for (const auto& [reason, n] : fetcher_.rejected()) s.rejected[reason] += n;
  for (const auto& [reason, n] : shared.rejected) s.rejected[reason] += n;
  for (const auto r : {EndpointRefusal::participant_limit, EndpointRefusal::domain_limit,
                       EndpointRefusal::topic_too_long, EndpointRefusal::topic_limit})
    if (const auto n = participants_.endpoints().refused(r)) s.endpoints_refused[to_string(r)] = n;
  s.rebuilds = rebuilds_;
  s.refreshes = refreshes_;
  if (!options_.interfaces_from_cyclone_config)
    for (const auto& i : options_.interfaces) s.interfaces.push_back({i.name, i.ipv4});
  s.network_changes = network_changes_;
  s.network_changed_at = network_changed_at_;
  s.complete = complete_locked();
  return s;
}

bool DomainSession::discovery_complete() const {
  std::lock_guard lock(mutex_);
  return complete_locked();
}

bool DomainSession::complete_locked() const {
  return state_ == DomainState::failed ||
         (first_reader_at_ && Clock::now() - *first_reader_at_ >= options_.initial_grace);
}

}  // namespace rsd::dds
