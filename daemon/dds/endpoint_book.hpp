// Every reader and writer on a DDS domain with its topic name, bounded, from
// Cyclone's DCPSPublication/DCPSSubscription: how many each participant has (the
// doctor's "heard, never answered" case), and who uses a camera's topics (its
// clients, and the streams they read). Pure: DomainSession feeds it under its
// lock, with the wall-clock time as text so tests give made-up ones.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::dds {

// Everything from the network is bounded: a peer making endpoints without end, or
// naming them with long or ever new topic names, is refused beyond these (the
// endpoint is then not kept, or kept without its topic), and counted.
struct EndpointLimits {
  std::size_t per_participant = 4096;  // a ROS 2 node has a few dozen, a realdds server ~10
  std::size_t per_domain = 65536;
  std::size_t topic_length = 256;  // bytes; realdds' longest is its topic-root + a stream name
  std::size_t topics = 8192;       // distinct topic names kept at once
};

enum class EndpointRefusal { none, participant_limit, domain_limit, topic_too_long, topic_limit };
// The reason as the log spells it ("participant-endpoint-limit" ...).
const char* to_string(EndpointRefusal r);

// How a realdds client names a camera's topics (librealsense's realdds sources,
// dds-topic-names.h, dds-device-impl.cpp, rs-dds-sensor-proxy.cpp; checked
// against a live pyrealdds server and client): `<root>/notification`,
// `<root>/control`, `<root>/metadata`, and each stream `rt/<root>_<stream name>`
// with the stream's name verbatim ("rt/realsense/D555_1_Infrared 1").
namespace realdds_topics {
inline constexpr std::string_view kNotification = "/notification";
inline constexpr std::string_view kControl = "/control";
inline constexpr std::string_view kMetadata = "/metadata";
inline constexpr std::string_view kStreamPrefix = "rt/";
// The topic-roots `topic` may belong to (a stream topic names its root only up to
// one of its '_'); the caller keeps those that are cameras.
std::vector<std::string> roots_of(std::string_view topic);
// `root` and each of its prefixes up to one of its '_': the cameras whose stream topics
// may have been counted for it before it was known.
std::set<std::string> root_and_prefixes(const std::string& root);
// Whether a topic-root is a known camera's (DomainBook's); an empty one knows none.
using KnownRoot = std::function<bool(std::string_view)>;
// The stream `topic` carries for the camera `root` ("Depth" of rt/<root>_Depth),
// or "" when it is no stream topic of that camera. A stream topic of another
// known camera whose root extends this one (rt/<root>_X_Depth, where <root>_X is
// a camera) is that camera's: the longest known root owns it.
std::string_view stream_of(std::string_view topic, std::string_view root, const KnownRoot& known = {});
// Whether `topic` is one a client of the camera `root` has.
bool is_camera_topic(std::string_view topic, std::string_view root, const KnownRoot& known = {});
}  // namespace realdds_topics

class EndpointBook {
 public:
  explicit EndpointBook(EndpointLimits limits = {}) : limits_(limits) {}

  // An endpoint was discovered (or its sample came again: nothing changes). A
  // refused topic keeps the endpoint counted, without its topic.
  EndpointRefusal alive(const std::string& participant, const std::string& endpoint, std::string_view topic,
                        bool reader, const std::string& now);
  // The topic of the endpoint that went ("" when it had none kept, or was unknown).
  std::string gone(const std::string& participant, const std::string& endpoint);
  // Every endpoint of a participant at once; returns their topics.
  std::vector<std::string> participant_gone(const std::string& participant);
  void clear();

  std::size_t count(const std::string& participant) const;
  // Whether the participant has a writer on `topic` (kept with its topic).
  bool writes(const std::string& participant, std::string_view topic) const;
  // The topic of one endpoint ("" when unknown or kept without it).
  std::string_view topic_of(const std::string& participant, const std::string& endpoint) const;
  std::size_t total() const { return total_; }
  std::size_t topics() const { return topics_.size(); }
  std::uint64_t refused(EndpointRefusal r) const;
  const EndpointLimits& limits() const { return limits_; }

  // A participant's use of one camera's topics.
  struct Use {
    std::string since;                // its first endpoint on them
    std::set<std::string> streams;    // read (a reader on the stream's topic)
    std::map<std::string, std::size_t> readers;  // per stream, its readers
  };
  // Every participant with a client's endpoint on the topics of the camera `root`
  // (a control writer, a reader of the others), but those in `except` (its servers);
  // `known` says the other cameras' roots, so one's streams are never another's.
  std::map<std::string, Use> users_of(const std::string& root, const std::set<std::string>& except,
                                      const realdds_topics::KnownRoot& known = {}) const;

 private:
  struct TopicUse {
    std::size_t readers = 0, writers = 0;
    std::string since;
  };
  using Topics = std::map<std::string, std::map<std::string, TopicUse>, std::less<>>;  // topic -> participant
  struct Endpoint {
    Topics::iterator topic;  // topics_.end(): kept without its topic
    bool reader = false;
  };
  void drop(const std::string& participant, const Endpoint& e);

  EndpointLimits limits_;
  Topics topics_;
  std::map<std::string, std::map<std::string, Endpoint>> endpoints_;  // participant -> endpoint GUID
  std::size_t total_ = 0;
  std::uint64_t refused_[5] = {};
};

}  // namespace rsd::dds
