// EndpointBook: endpoints by participant and by topic, bounded (endpoint_book.hpp).
#include "dds/endpoint_book.hpp"

#include "status/reasons.hpp"

#include <algorithm>

namespace rsd::dds {

const char* to_string(EndpointRefusal r) {
  switch (r) {
    case EndpointRefusal::none: return "none";
    case EndpointRefusal::participant_limit: return kParticipantEndpointLimit;
    case EndpointRefusal::domain_limit: return kDomainEndpointLimit;
    case EndpointRefusal::topic_too_long: return kTopicNameTooLong;
    case EndpointRefusal::topic_limit: return kDomainTopicLimit;
  }
  return "none";
}

namespace realdds_topics {

std::vector<std::string> roots_of(std::string_view topic) {
  std::vector<std::string> out;
  for (const auto suffix : {kNotification, kControl, kMetadata})
    if (topic.size() > suffix.size() && topic.ends_with(suffix)) {
      out.emplace_back(topic.substr(0, topic.size() - suffix.size()));
      return out;
    }
  if (!topic.starts_with(kStreamPrefix)) return out;
  const std::string_view rest = topic.substr(kStreamPrefix.size());
  for (std::size_t i = rest.find('_'); i != std::string_view::npos; i = rest.find('_', i + 1))
    if (i > 0 && i + 1 < rest.size()) out.emplace_back(rest.substr(0, i));
  return out;
}

std::set<std::string> root_and_prefixes(const std::string& root) {
  std::set<std::string> out{root};
  for (std::size_t u = root.find('_'); u != std::string::npos; u = root.find('_', u + 1)) out.insert(root.substr(0, u));
  return out;
}

std::string_view stream_of(std::string_view topic, std::string_view root, const KnownRoot& known) {
  if (!topic.starts_with(kStreamPrefix)) return {};
  const std::string_view rest = topic.substr(kStreamPrefix.size());
  if (rest.size() <= root.size() + 1 || !rest.starts_with(root) || rest[root.size()] != '_') return {};
  const std::string_view stream = rest.substr(root.size() + 1);
  if (known)
    for (std::size_t i = stream.find('_'); i != std::string_view::npos; i = stream.find('_', i + 1))
      if (i > 0 && i + 1 < stream.size() && known(rest.substr(0, root.size() + 1 + i))) return {};
  return stream;
}

bool is_camera_topic(std::string_view topic, std::string_view root, const KnownRoot& known) {
  for (const auto suffix : {kNotification, kControl, kMetadata})
    if (!root.empty() && topic.size() == root.size() + suffix.size() && topic.starts_with(root) && topic.ends_with(suffix))
      return true;
  return !stream_of(topic, root, known).empty();
}

}  // namespace realdds_topics

EndpointRefusal EndpointBook::alive(const std::string& participant, const std::string& endpoint,
                                    std::string_view topic, bool reader, const std::string& now) {
  auto of = endpoints_.find(participant);
  if (of != endpoints_.end() && of->second.count(endpoint)) return EndpointRefusal::none;  // known
  auto refuse = [&](EndpointRefusal r) {
    ++refused_[static_cast<int>(r)];
    return r;
  };
  if (total_ >= limits_.per_domain) return refuse(EndpointRefusal::domain_limit);
  if (of != endpoints_.end() && of->second.size() >= limits_.per_participant)
    return refuse(EndpointRefusal::participant_limit);
  Endpoint e{topics_.end(), reader};
  EndpointRefusal topic_refused = EndpointRefusal::none;
  if (topic.size() > limits_.topic_length) {
    topic_refused = refuse(EndpointRefusal::topic_too_long);
  } else if (auto t = topics_.find(topic); t != topics_.end()) {
    e.topic = t;
  } else if (topics_.size() >= limits_.topics) {
    topic_refused = refuse(EndpointRefusal::topic_limit);
  } else {
    e.topic = topics_.emplace(std::string(topic), Topics::mapped_type{}).first;
  }
  if (e.topic != topics_.end()) {
    auto& use = e.topic->second[participant];
    if (use.since.empty()) use.since = now;
    ++(reader ? use.readers : use.writers);
  }
  if (of == endpoints_.end()) of = endpoints_.emplace(participant, std::map<std::string, Endpoint>{}).first;
  of->second.emplace(endpoint, e);
  ++total_;
  return topic_refused;
}

void EndpointBook::drop(const std::string& participant, const Endpoint& e) {
  --total_;
  if (e.topic == topics_.end()) return;
  auto& users = e.topic->second;
  if (auto u = users.find(participant); u != users.end()) {
    --(e.reader ? u->second.readers : u->second.writers);
    if (u->second.readers + u->second.writers == 0) users.erase(u);
  }
  if (users.empty()) topics_.erase(e.topic);
}

std::string EndpointBook::gone(const std::string& participant, const std::string& endpoint) {
  const auto of = endpoints_.find(participant);
  if (of == endpoints_.end()) return {};
  const auto it = of->second.find(endpoint);
  if (it == of->second.end()) return {};
  std::string topic = it->second.topic != topics_.end() ? it->second.topic->first : std::string();
  drop(participant, it->second);
  of->second.erase(it);
  if (of->second.empty()) endpoints_.erase(of);
  return topic;
}

std::vector<std::string> EndpointBook::participant_gone(const std::string& participant) {
  std::vector<std::string> topics;
  const auto of = endpoints_.find(participant);
  if (of == endpoints_.end()) return topics;
  for (const auto& [guid, e] : of->second) {
    if (e.topic != topics_.end() && std::find(topics.begin(), topics.end(), e.topic->first) == topics.end())
      topics.push_back(e.topic->first);
    drop(participant, e);
  }
  endpoints_.erase(of);
  return topics;
}

void EndpointBook::clear() {
  endpoints_.clear();
  topics_.clear();
  total_ = 0;
}

std::size_t EndpointBook::count(const std::string& participant) const {
  const auto of = endpoints_.find(participant);
  return of == endpoints_.end() ? 0 : of->second.size();
}

bool EndpointBook::writes(const std::string& participant, std::string_view topic) const {
  const auto t = topics_.find(topic);
  if (t == topics_.end()) return false;
  const auto p = t->second.find(participant);
  return p != t->second.end() && p->second.writers > 0;
}

std::string_view EndpointBook::topic_of(const std::string& participant, const std::string& endpoint) const {
  const auto of = endpoints_.find(participant);
  if (of == endpoints_.end()) return {};
  const auto e = of->second.find(endpoint);
  if (e == of->second.end() || e->second.topic == topics_.end()) return {};
  return e->second.topic->first;
}

std::uint64_t EndpointBook::refused(EndpointRefusal r) const { return refused_[static_cast<int>(r)]; }

std::map<std::string, EndpointBook::Use> EndpointBook::users_of(const std::string& root,
                                                                const std::set<std::string>& except,
                                                                const realdds_topics::KnownRoot& known) const {
  std::map<std::string, Use> out;
  // A client writes the camera's control and reads the rest; a server (a second
  // one starting before its device-info is heard, too) does the opposite, so only
  // the client's direction counts.
  const auto take = [&](const Topics::value_type& topic, bool client_writes, std::string_view stream) {
    for (const auto& [participant, use] : topic.second) {
      if (except.count(participant) || (client_writes ? use.writers : use.readers) == 0) continue;
      Use& u = out[participant];
      if (u.since.empty() || use.since < u.since) u.since = use.since;
      if (!stream.empty()) {
        u.streams.emplace(stream);
        u.readers[std::string(stream)] += use.readers;
      }
    }
  };
  if (auto t = topics_.find(root + std::string(realdds_topics::kControl)); t != topics_.end()) take(*t, true, {});
  for (const auto suffix : {realdds_topics::kNotification, realdds_topics::kMetadata})
    if (auto t = topics_.find(root + std::string(suffix)); t != topics_.end()) take(*t, false, {});
  const std::string prefix = std::string(realdds_topics::kStreamPrefix) + root + "_";
  for (auto t = topics_.lower_bound(prefix); t != topics_.end() && t->first.starts_with(prefix); ++t)
    if (const auto stream = realdds_topics::stream_of(t->first, root, known); !stream.empty()) take(*t, false, stream);
  return out;
}

}  // namespace rsd::dds
