// The Cyclone side of USB sharing: rs-discoveryd/shared-usb's reader and writer.
#include "dds/share_session.hpp"

#include "dds/domain_session.hpp"
#include "dds/flexible_topic.hpp"
#include "dds/take_batches.hpp"
#include "log/log.hpp"

#include "shared_usb.h"

#include <unistd.h>

#include <array>
#include <cstring>
#include <optional>
#include <variant>

namespace rsd::dds {
namespace {

const dds_topic_descriptor_t* shared_usb_descriptor() {
  // Without type information, as realdds' type (flexible_topic.hpp): a peer's type
  // object is untrusted input the daemon does not need.
  static const dds_topic_descriptor_t without = without_type_information(rsd_share_usb_camera_desc);
  return &without;
}

std::string host_name() {
  char buf[256] = {};
  if (gethostname(buf, sizeof buf - 1) != 0) return "localhost";
  return buf;
}

// A bounded string field of the sample (char[N + 1]): at most N bytes, always terminated.
template <std::size_t N>
void put(char (&field)[N], const std::string& value) {
  std::memset(field, 0, N);
  std::memcpy(field, value.data(), std::min(value.size(), N - 1));
}

template <std::size_t N>
std::string_view get(const char (&field)[N]) {
  return std::string_view(field, strnlen(field, N));
}

// The writer's QoS and the reader's must agree: reliable, transient-local (a
// daemon started later is given every camera at once), the last sample of each
// camera.
dds_qos_t* share_qos() {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
  dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
  return qos;
}

}  // namespace

ShareSession::ShareSession(SharedTable& table, ShareOptions options)
    : options_(std::move(options)), book_(table, options_.book) {
  if (options_.host_name.empty()) options_.host_name = host_name();
  if (options_.host_name.size() > kMaxHostKey) options_.host_name.resize(kMaxHostKey);
}

ShareSession::~ShareSession() { stop(true); }

std::string ShareSession::start(dds_entity_t participant, const std::string& own_guid, Clock::time_point now) {
  {
    std::lock_guard lock(mutex_);
    book_.set_own_participant(own_guid);
    book_.reader_made(now);
    writer_participants_.clear();
  }
  dds_qos_t* qos = share_qos();
  topic_ = create_topic_allowing_dash(participant, shared_usb_descriptor(), kSharedUsbTopic, qos);
  if (topic_ < 0) {
    const std::string why = std::string("cannot create topic ") + kSharedUsbTopic + ": " + dds_strretcode(topic_);
    topic_ = 0;
    dds_delete_qos(qos);
    return why;
  }
  if (options_.share) {
    // Deleting the writer only unregisters: a participant made anew (a refresh)
    // takes its cameras over without other hosts seeing them go. Leaving for good
    // disposes them first (stop).
    dds_qos_t* wqos = dds_create_qos();
    dds_copy_qos(wqos, qos);
    dds_qset_writer_data_lifecycle(wqos, false);
    writer_ = dds_create_writer(participant, topic_, wqos, nullptr);
    dds_delete_qos(wqos);
    if (writer_ < 0) {
      const std::string why = std::string("cannot share USB cameras: ") + dds_strretcode(writer_);
      writer_ = 0;
      dds_delete_qos(qos);
      return why;
    }
    published_.clear();
  }
  // Not the daemon's own cameras (they are listed as "usb" already). A flood of
  // instances is bounded here too: Cyclone keeps at most this many (each is a
  // camera of some host), the book refuses beyond its caps.
  dds_qset_ignorelocal(qos, DDS_IGNORELOCAL_PARTICIPANT);
  const auto max_instances = static_cast<std::int32_t>(std::min<std::size_t>(options_.book.max_per_domain * 4, 65536));
  dds_qset_resource_limits(qos, DDS_LENGTH_UNLIMITED, max_instances, 1);
  dds_listener_t* listener = dds_create_listener(this);
  dds_lset_data_available(listener, &ShareSession::on_data_available);
  reader_ = dds_create_reader(participant, topic_, qos, listener);
  dds_delete_listener(listener);
  dds_delete_qos(qos);
  if (reader_ < 0) {
    const std::string why = std::string("cannot read shared USB cameras: ") + dds_strretcode(reader_);
    reader_ = 0;
    return why;
  }
  return "";
}

void ShareSession::stop(bool for_good) {
  // The writer first. Leaving for good, every camera it announced is disposed, so
  // other hosts drop them now rather than at lease expiry.
  if (writer_ > 0 && for_good)
    for (const auto& [camera, payload] : published_) dispose(camera);
  if (writer_ > 0) dds_delete(writer_);
  writer_ = 0;
  published_.clear();
  if (reader_ > 0) {
    dds_set_listener(reader_, nullptr);  // waits for a listener call under way
    dds_delete(reader_);
  }
  reader_ = 0;
  if (topic_ > 0) dds_delete(topic_);
  topic_ = 0;
}

void ShareSession::publish(const std::map<std::string, nlohmann::json>& cameras,
                           const std::vector<std::string>& addresses) {
  if (writer_ <= 0) return;
  for (const auto& [camera, doc] : cameras) {
    if (camera.size() > kMaxCameraKey) continue;  // never the USB source's ids
    std::string payload = shared_usb_payload(options_.host_name, addresses, doc);
    auto it = published_.find(camera);
    if (it != published_.end() && it->second == payload) continue;
    if (write(camera, payload)) published_[camera] = std::move(payload);
  }
  for (auto it = published_.begin(); it != published_.end();) {
    if (cameras.count(it->first)) {
      ++it;
      continue;
    }
    dispose(it->first);
    it = published_.erase(it);
  }
}

bool ShareSession::write(const std::string& camera, const std::string& payload) {
  if (payload.size() > kMaxPayload) {
    log::warning(log::domain_prefix(options_.book.domain) + "not sharing " + camera + ": its document is too large");
    return false;
  }
  rsd_share_usb_camera sample{};
  put(sample.host, options_.host_name);
  put(sample.camera, camera);
  sample.version = kSharedUsbVersion;
  sample.data._buffer = reinterpret_cast<std::uint8_t*>(const_cast<char*>(payload.data()));
  sample.data._length = static_cast<std::uint32_t>(payload.size());
  sample.data._maximum = sample.data._length;
  sample.data._release = false;
  const dds_return_t rc = dds_write(writer_, &sample);
  if (rc < 0) {
    log::warning(log::domain_prefix(options_.book.domain) + "sharing " + camera + " failed: " + dds_strretcode(rc));
    return false;
  }
  log::info(log::domain_prefix(options_.book.domain) + "sharing " + camera + " as " + options_.host_name);
  return true;
}

void ShareSession::dispose(const std::string& camera) {
  rsd_share_usb_camera key{};
  put(key.host, options_.host_name);
  put(key.camera, camera);
  if (const dds_return_t rc = dds_dispose(writer_, &key); rc < 0)
    log::warning(log::domain_prefix(options_.book.domain) + "unsharing " + camera + " failed: " + dds_strretcode(rc));
  else
    log::info(log::domain_prefix(options_.book.domain) + "no longer sharing " + camera);
}

ShareSession::Clock::duration ShareSession::tick(Clock::time_point now) {
  std::lock_guard lock(mutex_);
  return book_.tick(now);
}

void ShareSession::forget_devices(model::RemovalReason reason) {
  std::lock_guard lock(mutex_);
  book_.forget_devices(reason);
}

void ShareSession::fill(DomainStatus& status) const {
  std::lock_guard lock(mutex_);
  book_.fill(status);
}

void ShareSession::on_data_available(dds_entity_t reader, void* arg) {
  // Cyclone's thread: nothing may be thrown back into it.
  try {
    static_cast<ShareSession*>(arg)->take_samples(reader);
  } catch (const std::exception& e) {
    log::error(std::string("shared-usb listener: ") + e.what());
  }
}

std::string ShareSession::participant_of_writer(dds_entity_t reader, dds_instance_handle_t writer) {
  {
    std::lock_guard lock(mutex_);
    if (auto it = writer_participants_.find(writer); it != writer_participants_.end()) return it->second;
  }
  // Asked of Cyclone outside the lock (a lock is never held across a call into it).
  std::string guid;
  if (dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, writer)) {
    guid = guid_to_string(ep->participant_key);
    dds_builtintopic_free_endpoint(ep);
  }
  std::lock_guard lock(mutex_);
  // Bounded like the reader's instances: a flood of writers cannot grow it for good.
  if (writer_participants_.size() >= 4096) writer_participants_.clear();
  if (!guid.empty()) writer_participants_.emplace(writer, guid);
  return guid;
}

void ShareSession::take_samples(dds_entity_t reader) {
  take_batches(reader, [&](std::span<void* const> samples, std::span<const dds_sample_info_t> infos) {
    // Parsed and identified outside the lock (the lookup calls into Cyclone), then
    // handed to the book at once.
    struct Item {
      dds_instance_handle_t instance;
      std::string participant;
      std::optional<std::variant<SharedCamera, Rejected>> parsed;  // none: the camera is gone
      bool disposed = false;
    };
    std::vector<Item> items;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const auto& info = infos[i];
      if (info.instance_state != DDS_IST_ALIVE) {
        // Disposed (unplugged, the sharer stopped): gone. No writer left (the
        // sharer made anew, or its lease expired): gone unless a writer takes it over.
        items.push_back({info.instance_handle, {}, std::nullopt, info.instance_state == DDS_IST_NOT_ALIVE_DISPOSED});
        continue;
      }
      if (!info.valid_data) continue;
      const auto* s = static_cast<const rsd_share_usb_camera*>(samples[i]);
      std::string participant = participant_of_writer(reader, info.publication_handle);
      auto parsed = parse_shared_usb(options_.book.domain, get(s->host), get(s->camera), s->version,
                                     std::span<const std::uint8_t>(s->data._buffer, s->data._length), participant);
      items.push_back({info.instance_handle, std::move(participant), std::move(parsed), false});
    }
    {
      const auto now = Clock::now();
      std::lock_guard lock(mutex_);
      for (auto& item : items) {
        if (item.parsed)
          book_.sample(item.instance, item.participant, std::move(*item.parsed));
        else
          book_.instance_gone(item.instance, item.disposed, now);
      }
    }
  });
}

}  // namespace rsd::dds
