#include "dds/participant_book.hpp"

#include <algorithm>

namespace rsd::dds {

void ParticipantBook::alive(ParticipantSighting s, const std::string& now) {
  model::Participant* p = nullptr;
  if (auto it = alive_.find(s.guid); it != alive_.end()) {
    p = &it->second;  // its announcement changed (a new name, an address more)
  } else {
    if (alive_.size() >= max_alive_) {
      ++unlisted_;
      return;
    }
    p = &alive_[s.guid];
    p->first_seen = now;
    // Back after being lost: one entry for it, the alive one.
    std::erase_if(gone_, [&](const model::Participant& g) { return g.guid == s.guid; });
  }
  p->guid = std::move(s.guid);
  p->name = std::move(s.name);
  p->vendor_id = model::vendor_id_of(p->guid);
  p->vendor = model::vendor_of(p->vendor_id);
  p->addresses = std::move(s.addresses);
  p->host = std::move(s.host);
  p->process = std::move(s.process);
  p->pid = s.pid;
  p->lease_seconds = s.lease_seconds;
  p->state = model::ParticipantState::alive;
}

std::vector<std::string> ParticipantBook::gone(const std::string& guid, const std::string& now) {
  std::vector<std::string> topics = endpoints_.participant_gone(guid);
  drop_ros_nodes(guid);
  std::size_t most = 0;
  if (auto m = most_endpoints_.find(guid); m != most_endpoints_.end()) {
    most = m->second;
    most_endpoints_.erase(m);
  }
  const auto it = alive_.find(guid);
  if (it == alive_.end()) {
    if (unlisted_ > 0) --unlisted_;  // one of those never listed
    return topics;
  }
  model::Participant p = std::move(it->second);
  alive_.erase(it);
  p.state = model::ParticipantState::gone;
  p.last_seen = now;
  // The most it had exchanged with the daemon (the doctor's "heard once, never
  // answered" case has none; a program that ended cleanly took its endpoints first).
  p.endpoints = most;
  gone_.push_back(std::move(p));
  while (gone_.size() > max_gone_) gone_.pop_front();
  return topics;
}

EndpointRefusal ParticipantBook::endpoint_alive(const std::string& participant, const std::string& endpoint,
                                                std::string_view topic, bool reader, const std::string& now) {
  const EndpointRefusal r = endpoints_.alive(participant, endpoint, topic, reader, now);
  if (const std::size_t n = endpoints_.count(participant); n > 0) {
    auto& most = most_endpoints_[participant];
    most = std::max(most, n);
  }
  return r;
}

bool ParticipantBook::ros_nodes(const std::string& participant, std::vector<RosNode> nodes) {
  drop_ros_nodes(participant);
  std::size_t endpoints = 0;
  for (const auto& n : nodes) endpoints += n.endpoints.size();
  if (nodes.empty()) return true;
  if (ros_nodes_.size() >= max_alive_ || endpoints > endpoints_.limits().per_domain - ros_endpoints_) return false;
  ros_endpoints_ += endpoints;
  ros_nodes_[participant] = std::move(nodes);
  return true;
}

void ParticipantBook::drop_ros_nodes(const std::string& participant) {
  const auto it = ros_nodes_.find(participant);
  if (it == ros_nodes_.end()) return;
  for (const auto& n : it->second) ros_endpoints_ -= n.endpoints.size();
  ros_nodes_.erase(it);
}

std::string ParticipantBook::endpoint_gone(const std::string& participant, const std::string& endpoint) {
  return endpoints_.gone(participant, endpoint);
}

model::DeviceClients ParticipantBook::clients(const std::string& topic_root, const std::set<std::string>& servers,
                                              const realdds_topics::KnownRoot& known) const {
  model::DeviceClients out;
  for (auto& [guid, use] : endpoints_.users_of(topic_root, servers, known)) {
    model::Client c;
    c.guid = guid;
    c.vendor_id = model::vendor_id_of(guid);
    c.vendor = model::vendor_of(c.vendor_id);
    if (auto p = alive_.find(guid); p != alive_.end()) {
      c.name = p->second.name;
      c.addresses = p->second.addresses;
      c.host = p->second.host;
      c.process = p->second.process;
      c.pid = p->second.pid;
    }
    c.since = use.since;
    c.streams.assign(use.streams.begin(), use.streams.end());
    // A ROS 2 node is named by the nodes owning its endpoints on this camera's
    // topics: one participant holds every node of its process.
    if (auto r = ros_nodes_.find(guid); r != ros_nodes_.end())
      for (const auto& node : r->second)
        if (std::any_of(node.endpoints.begin(), node.endpoints.end(), [&, &owner = guid](const std::string& e) {
              return realdds_topics::is_camera_topic(endpoints_.topic_of(owner, e), topic_root, known);
            }))
          c.ros_nodes.push_back(node.name);
    for (const auto& [stream, readers] : use.readers) out.streams[stream] += readers;
    out.clients.push_back(std::move(c));
  }
  return out;
}

void ParticipantBook::participant_rebuilt() {
  alive_.clear();
  unlisted_ = 0;
  endpoints_.clear();
  most_endpoints_.clear();
  ros_nodes_.clear();
  ros_endpoints_ = 0;
}

std::vector<model::Participant> ParticipantBook::list(int domain, const std::string& now,
                                                      const std::map<std::string, PublisherCounts>& publishers) const {
  std::vector<model::Participant> out;
  out.reserve(alive_.size() + gone_.size());
  for (const auto& [guid, p] : alive_) {
    out.push_back(p);
    out.back().last_seen = now;  // heard within its lease, or it would be gone
  }
  for (auto it = gone_.rbegin(); it != gone_.rend(); ++it) out.push_back(*it);
  for (auto& p : out) {
    p.domain = domain;
    if (p.state != model::ParticipantState::alive) continue;  // its writers went with it
    p.endpoints = endpoints_.count(p.guid);
    if (auto c = publishers.find(p.guid); c != publishers.end()) {
      p.topic_roots = c->second.topic_roots;
      p.device_info_writers = c->second.writers;
      p.devices = c->second.devices;
      p.silent_writers = c->second.silent;
      p.never_announced = c->second.never_announced;
    }
  }
  return out;
}

}  // namespace rsd::dds
