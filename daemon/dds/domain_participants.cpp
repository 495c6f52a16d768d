// Who is on a DDS domain: DomainSession's side of Cyclone's built-in topics
// (DCPSParticipant: names, addresses, leases, which participants are alive;
// DCPSPublication/DCPSSubscription: endpoints per participant), feeding the
// ParticipantBook and the DomainBook's lost-server tracking. Split from
// domain_session.cpp, which keeps the device-info reader and the lifecycle.
#include "dds/builtin_topics.hpp"
#include "dds/domain_session.hpp"
#include "dds/flexible_topic.hpp"  // without_type_information
#include "dds/ros_nodes.hpp"
#include "dds/take_batches.hpp"

#include "log/log.hpp"
#include "ros_discovery.h"

#include <dds/ddsi/ddsi_serdata.h>

#include <algorithm>
#include <array>
#include <cstdlib>

namespace rsd::dds {
namespace {

log::RateLimiter g_endpoint_log;
log::RateLimiter g_ros_log;

constexpr const char* kRosDiscoveryTopic = "ros_discovery_info";

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

}  // namespace

std::optional<ParticipantSighting> read_participant(dds_entity_t reader, dds_instance_handle_t handle) {
  ParticipantLoan loan{};
  dds_sample_info_t info{};
  if (dds_read_instance(reader, loan.data(), &info, kParticipantBatch, 1, handle) <= 0) return std::nullopt;
  const auto& p = *static_cast<const dds_builtintopic_participant_t*>(loan[0]);
  ParticipantSighting s;
  s.guid = guid_to_string(p.key);
  if (!p.qos) {
    dds_return_loan(reader, loan.data(), 1);
    return s;
  }
  // Untrusted text from the network: kept only when it is UTF-8 (the API is JSON).
  const auto text = [](char* value) -> std::optional<std::string> {
    std::optional<std::string> out;
    if (value && is_valid_utf8(value)) out = value;
    dds_free(value);
    return out;
  };
  char* value = nullptr;
  if (dds_qget_entity_name(p.qos, &value)) s.name = text(value).value_or("");
  value = nullptr;
  if (dds_qget_prop(p.qos, "__NetworkAddresses", &value)) {
    s.addresses = split_addresses(value);
    dds_free(value);
  }
  // Cyclone peers say where they run (measured: Fast DDS peers do not).
  value = nullptr;
  if (dds_qget_prop(p.qos, "__Hostname", &value)) s.host = text(value);
  value = nullptr;
  if (dds_qget_prop(p.qos, "__ProcessName", &value)) s.process = text(value);
  value = nullptr;
  if (dds_qget_prop(p.qos, "__Pid", &value)) {
    if (auto pid = text(value)) {
      char* end = nullptr;
      const long long n = std::strtoll(pid->c_str(), &end, 10);
      if (end && *end == '\0' && !pid->empty() && n > 0) s.pid = n;
    }
  }
  dds_liveliness_kind_t kind{};
  dds_duration_t lease = 0;
  if (dds_qget_liveliness(p.qos, &kind, &lease) && lease > 0 && lease != DDS_INFINITY)
    s.lease_seconds = static_cast<double>(lease) / 1e9;
  dds_return_loan(reader, loan.data(), 1);
  return s;
}

void DomainSession::create_builtin_readers() {
  // Read, never taken: Cyclone keeps each live participant's sample here, so a
  // writer's participant name and addresses can be looked up by instance handle.
  // Its listener also tells which participants are alive, to tell a lost server
  // (participant gone) from one that only dropped a device (participant alive).
  dds_listener_t* participant_listener = dds_create_listener(this);
  dds_lset_data_available(participant_listener, &DomainSession::on_participant_data);
  participant_reader_ =
      dds_create_reader(participant_, DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, nullptr, participant_listener);
  dds_delete_listener(participant_listener);
  // Every reader and writer of the domain's participants, counted per participant
  // (taken, not kept): a participant heard but with none was reached by multicast
  // only, the doctor's "firewall" case.
  // Two callbacks, one per topic, so each knows its endpoints' kind from the start.
  for (const bool readers : {false, true}) {
    dds_listener_t* endpoint_listener = dds_create_listener(this);
    dds_lset_data_available(endpoint_listener, readers ? &DomainSession::on_subscription_data : &DomainSession::on_publication_data);
    dds_create_reader(participant_, readers ? DDS_BUILTIN_TOPIC_DCPSSUBSCRIPTION : DDS_BUILTIN_TOPIC_DCPSPUBLICATION,
                      nullptr, endpoint_listener);
    dds_delete_listener(endpoint_listener);
  }
  // ROS 2 participants' nodes, to name the ROS 2 nodes among a camera's clients.
  // rmw's QoS: late joiners get each participant's latest sample. A failure costs
  // the node names only.
  static const dds_topic_descriptor_t descriptor =
      without_type_information(rmw_dds_common_msg_dds__ParticipantEntitiesInfo__desc);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
  // No key: every participant's samples share one instance, so the history holds
  // a burst of them until the listener takes it.
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 256);
  const dds_entity_t topic = dds_create_topic(participant_, &descriptor, kRosDiscoveryTopic, qos, nullptr);
  dds_listener_t* ros_listener = dds_create_listener(this);
  dds_lset_data_available(ros_listener, &DomainSession::on_ros_discovery_data);
  const dds_entity_t reader = topic < 0 ? topic : dds_create_reader(participant_, topic, qos, ros_listener);
  dds_delete_listener(ros_listener);
  dds_delete_qos(qos);
  if (reader < 0)
    log::warning(log::domain_prefix(options_.domain) + "no ROS 2 node names: cannot read ros_discovery_info: " +
                 dds_strretcode(reader));
}

void DomainSession::on_participant_data(dds_entity_t reader, void* arg) {
  try {
    auto* self = static_cast<DomainSession*>(arg);
    self->take_participant_changes(reader);
    self->wake();  // a participant gone may be a lost server, timed from now
  } catch (const std::exception& e) {
    log::error(std::string("participant listener: ") + e.what());
  }
}


void DomainSession::take_participant_changes(dds_entity_t reader) {
  // Only samples not read before: each is a participant appearing, changing or
  // leaving. Alive ones are read, not taken, so identify() can still look names
  // up; a gone one is taken, or Cyclone would keep every peer that ever came by.
  ParticipantLoan samples{};
  std::array<dds_sample_info_t, kParticipantBatch> infos{};
  struct Change {
    dds_instance_handle_t handle;
    std::string guid;
    dds_instance_state_t state;
  };
  std::vector<Change> changes;
  for (;;) {
    samples.fill(nullptr);
    const dds_return_t n = dds_read_mask(reader, samples.data(), infos.data(), kParticipantBatch, kParticipantBatch,
                                         DDS_NOT_READ_SAMPLE_STATE | DDS_ANY_VIEW_STATE | DDS_ANY_INSTANCE_STATE);
    if (n <= 0) break;
    for (dds_return_t i = 0; i < n; ++i) {
      const auto& info = infos[static_cast<std::size_t>(i)];
      const auto* p = static_cast<const dds_builtintopic_participant_t*>(samples[static_cast<std::size_t>(i)]);
      changes.push_back({info.instance_handle, guid_to_string(p->key), info.instance_state});
    }
    dds_return_loan(reader, samples.data(), n);
    if (static_cast<std::size_t>(n) < kParticipantBatch) break;
  }
  if (changes.empty()) return;
  const std::string now = SharedTable::now_iso8601();
  for (const auto& c : changes) {
    const bool alive = c.state == DDS_IST_ALIVE;
    std::optional<ParticipantSighting> sighting;
    if (alive) sighting = read_participant(reader, c.handle);
    std::lock_guard lock(mutex_);
    if (alive) {
      book_.participant_alive(c.guid, Clock::now());
      if (sighting && c.guid != participant_guid_) participants_.alive(std::move(*sighting), now);
    } else {
      book_.participant_gone(c.guid, Clock::now());
      update_in_use_of_topics(participants_.gone(c.guid, now));  // a client gone
    }
    log::debug([&] { return log::domain_prefix(options_.domain) + "participant " + c.guid + (alive ? " alive" : " gone"); });
  }
  for (const auto& c : changes) {
    if (c.state == DDS_IST_ALIVE) continue;
    ParticipantLoan loan{};
    std::array<dds_sample_info_t, kParticipantBatch> info{};
    const dds_return_t n = dds_take_instance(reader, loan.data(), info.data(), kParticipantBatch, kParticipantBatch, c.handle);
    if (n > 0) dds_return_loan(reader, loan.data(), n);
  }
}


void DomainSession::on_publication_data(dds_entity_t reader, void* arg) {
  try {
    static_cast<DomainSession*>(arg)->take_endpoint_changes(reader, false);
  } catch (const std::exception& e) {
    log::error(std::string("endpoint listener: ") + e.what());
  }
}

void DomainSession::on_subscription_data(dds_entity_t reader, void* arg) {
  try {
    static_cast<DomainSession*>(arg)->take_endpoint_changes(reader, true);
  } catch (const std::exception& e) {
    log::error(std::string("endpoint listener: ") + e.what());
  }
}


void DomainSession::take_endpoint_changes(dds_entity_t reader, bool readers) {
  const std::string now = SharedTable::now_iso8601();
  bool device_info_writer = false;  // one the main loop may be waiting for (servers_heard)
  take_batches(reader, [&](std::span<void* const> samples, std::span<const dds_sample_info_t> infos) {
    std::vector<std::string> topics;  // touched by the batch: the cameras' summaries follow once, after it
    std::lock_guard lock(mutex_);
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const auto* ep = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
      // The key is there in every sample, the rest only in valid ones; an
      // endpoint's GUID begins with its participant's prefix.
      const std::string guid = guid_to_string(ep->key);
      const std::string participant = participant_of(guid);
      if (participant == participant_guid_) continue;  // the daemon's own (describe's reader) is no client
      if (infos[i].instance_state == DDS_IST_ALIVE) {
        const std::string_view topic = infos[i].valid_data && ep->topic_name ? ep->topic_name : "";
        const EndpointRefusal r = participants_.endpoint_alive(participant, guid, topic, readers, now);
        if (r != EndpointRefusal::none) refuse_endpoint(r, participant, topic.size());
        else topics.emplace_back(topic);
        device_info_writer = device_info_writer || (!readers && topic == kDeviceInfoTopic);
      } else if (std::string topic = participants_.endpoint_gone(participant, guid); !topic.empty()) {
        topics.push_back(std::move(topic));
      }
    }
    update_in_use_of_topics(topics);
  });
  if (device_info_writer) wake();
}

void DomainSession::on_ros_discovery_data(dds_entity_t reader, void* arg) {
  try {
    static_cast<DomainSession*>(arg)->take_ros_discovery(reader);
  } catch (const std::exception& e) {
    log::error(std::string("ros_discovery_info listener: ") + e.what());
  }
}

void DomainSession::take_ros_discovery(dds_entity_t reader) {
  // Serialized, as received: the sample's GID size is the ROS 2 release's, which
  // no one type describes (proto/ros_discovery.idl), so ros_nodes.cpp reads it.
  constexpr std::uint32_t kBatch = 16;
  std::array<ddsi_serdata*, kBatch> samples{};
  std::array<dds_sample_info_t, kBatch> infos{};
  const RosInfoLimits limits;
  for (;;) {
    const dds_return_t n = dds_takecdr(reader, samples.data(), kBatch, infos.data(), DDS_ANY_STATE);
    if (n <= 0) return;
    for (dds_return_t i = 0; i < n; ++i) {
      ddsi_serdata* sample = samples[static_cast<std::size_t>(i)];
      const dds_sample_info_t& info = infos[static_cast<std::size_t>(i)];
      std::optional<RosParticipantInfo> parsed;
      std::string writer;
      if (info.valid_data && ddsi_serdata_size(sample) <= limits.bytes) {
        std::vector<unsigned char> bytes(ddsi_serdata_size(sample));
        ddsi_serdata_to_ser(sample, 0, bytes.size(), bytes.data());
        parsed = parse_ros_discovery_info(bytes, limits);
        if (dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, info.publication_handle)) {
          writer = guid_to_string(ep->participant_key);
          dds_builtintopic_free_endpoint(ep);
        }
      }
      ddsi_serdata_unref(sample);
      if (!info.valid_data) continue;
      // A participant speaks for itself only: a sample naming another is refused.
      const char* refused = !parsed                          ? "malformed"
                            : parsed->participant != writer ? "about another participant"
                                                            : nullptr;
      if (!refused) {
        std::lock_guard lock(mutex_);
        if (!participants_.ros_nodes(parsed->participant, std::move(parsed->nodes))) refused = "beyond the bounds";
      }
      std::uint64_t suppressed = 0;
      if (refused && g_ros_log.allow(std::to_string(options_.domain) + "/ros", suppressed))
        log::warning(log::domain_prefix(options_.domain) + "ros_discovery_info from " +
                     (writer.empty() ? "an unknown writer" : writer) + " refused: " + refused +
                     (suppressed ? "; " + std::to_string(suppressed) + " more like it suppressed" : ""));
    }
    if (static_cast<std::uint32_t>(n) < kBatch) return;
  }
}

void DomainSession::refuse_endpoint(EndpointRefusal r, const std::string& participant, std::size_t topic_length) {
  std::uint64_t suppressed = 0;
  // Keyed by domain and reason, not by peer: a flood from ever new GUIDs would grow
  // the limiter by a slot each.
  if (!g_endpoint_log.allow(std::to_string(options_.domain) + "/" + to_string(r), suppressed))
    return;
  log::warning(log::domain_prefix(options_.domain) + "endpoint of " + participant + " refused: " + to_string(r) +
               " (topic name of " + std::to_string(topic_length) + " bytes; " +
               std::to_string(participants_.endpoints().total()) + " endpoints and " +
               std::to_string(participants_.endpoints().topics()) + " topics kept)" +
               (suppressed ? "; " + std::to_string(suppressed) + " more like it suppressed" : ""));
}

void DomainSession::update_in_use_of_topics(const std::vector<std::string>& topics) {
  std::set<std::string> roots;
  for (const auto& t : topics)
    for (auto& r : realdds_topics::roots_of(t)) roots.insert(std::move(r));
  update_in_use(roots);
}

void DomainSession::update_in_use(const std::set<std::string>& roots) {
  bool held = false;
  for (const auto& root : roots)
    if (auto servers = book_.servers_of(root))
      held = book_.set_in_use(root, model::summary_of(participants_.clients(root, *servers, known_root())),
                              Clock::now()) || held;
  if (held) wake();  // the main loop sleeps past a hold it does not know of: tick() writes it
}

realdds_topics::KnownRoot DomainSession::known_root() const {
  return [this](std::string_view root) { return book_.has_device(root); };
}

std::optional<model::DeviceClients> DomainSession::clients(const std::string& topic_root) const {
  std::lock_guard lock(mutex_);
  auto servers = book_.servers_of(topic_root);
  if (!servers) return std::nullopt;
  return participants_.clients(topic_root, *servers, known_root());
}

std::vector<model::Participant> DomainSession::participants() const {
  const std::string now = SharedTable::now_iso8601();
  std::lock_guard lock(mutex_);
  return participants_.list(options_.domain, now, book_.publishers(Clock::now()));
}


}  // namespace rsd::dds
