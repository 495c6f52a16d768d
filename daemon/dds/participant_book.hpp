// Who is on a domain: every DDS participant the daemon's own participant has
// heard, alive or recently gone, for /v1/participants and `rs-discover doctor`.
// Pure bookkeeping fed by DomainSession from Cyclone's DCPSParticipant reader;
// the wall-clock times come in as text so tests give made-up ones.
#pragma once

#include "dds/endpoint_book.hpp"
#include "dds/ros_nodes.hpp"
#include "rsd_model/clients.hpp"
#include "rsd_model/participant.hpp"

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace rsd::dds {

// What DDS tells of a participant (its SPDP announcement, as Cyclone keeps it).
struct ParticipantSighting {
  std::string guid;
  std::string name;
  std::vector<std::string> addresses;
  std::optional<std::string> host, process;
  std::optional<std::int64_t> pid;
  std::optional<double> lease_seconds;
};

// A participant's writers on realsense/device-info, from DomainBook::publishers.
struct PublisherCounts {
  std::size_t writers = 0, devices = 0, silent = 0;
  bool never_announced = false;  // see model::Participant
  std::vector<std::string> topic_roots;
};

class ParticipantBook {
 public:
  // Bounds, so a domain full of short-lived peers (a test rig restarting a
  // thousand times) cannot grow the daemon: alive ones beyond `max_alive` are
  // not listed (counted in `unlisted`), and only the latest `max_gone` of those
  // gone are remembered.
  explicit ParticipantBook(std::size_t max_alive = 4096, std::size_t max_gone = 256, EndpointLimits limits = {})
      : max_alive_(max_alive), max_gone_(max_gone), endpoints_(limits) {}

  // Heard (first time, or its announcement changed, or back after being gone).
  void alive(ParticipantSighting sighting, const std::string& now);
  // It said goodbye or its lease ran out (Cyclone tells neither apart). Returns
  // the topics its endpoints were on (the cameras whose clients may have changed).
  std::vector<std::string> gone(const std::string& guid, const std::string& now);
  // An endpoint (reader or writer, any topic) of a participant was discovered, or
  // went. Participants are named by GUID prefix (an endpoint's GUID shares its
  // participant's), so the order against alive() does not matter. `gone` returns
  // the endpoint's topic ("" if none was kept).
  EndpointRefusal endpoint_alive(const std::string& participant, const std::string& endpoint, std::string_view topic,
                                 bool reader, const std::string& now);
  std::string endpoint_gone(const std::string& participant, const std::string& endpoint);
  const EndpointBook& endpoints() const { return endpoints_; }
  // A participant's ROS 2 nodes, from its latest ros_discovery_info (which says
  // them all), kept until it goes. Refused (false) beyond the bounds: as many
  // participants as are listed, as many node endpoints as a domain's endpoints.
  bool ros_nodes(const std::string& participant, std::vector<RosNode> nodes);

  // The clients of the camera `topic_root`: every participant but its `servers` with
  // an endpoint on its topics (EndpointBook::users_of), named from its announcement
  // when it has been heard, and the streams read now with their readers. `known`
  // says which roots are cameras (a stream of a longer known root is not this one's).
  model::DeviceClients clients(const std::string& topic_root, const std::set<std::string>& servers,
                               const realdds_topics::KnownRoot& known = {}) const;

  // The daemon's participant was made anew: it hears every alive peer again and
  // those it does not are not there; the gone ones are kept.
  void participant_rebuilt();

  // Every participant, alive first then the gone ones latest first; `publishers`
  // by participant GUID, from DomainBook.
  std::vector<model::Participant> list(int domain, const std::string& now,
                                       const std::map<std::string, PublisherCounts>& publishers) const;
  std::size_t unlisted() const { return unlisted_; }

 private:
  std::size_t max_alive_, max_gone_;
  std::map<std::string, model::Participant> alive_;  // by GUID
  std::deque<model::Participant> gone_;               // oldest first
  std::size_t unlisted_ = 0;
  // Endpoints with their topics, by participant; bounded (EndpointLimits).
  EndpointBook endpoints_;
  // The most endpoints each participant had at once: a program that ends cleanly
  // disposes its endpoints before its participant, so by gone() it has none left,
  // like one whose unicast never got through; this keeps them apart for the doctor.
  // An entry per participant with endpoints_ (bounded with it), dropped at gone().
  std::map<std::string, std::size_t> most_endpoints_;
  std::map<std::string, std::vector<RosNode>> ros_nodes_;  // by participant GUID
  std::size_t ros_endpoints_ = 0;                          // over all of ros_nodes_
  void drop_ros_nodes(const std::string& participant);
};

}  // namespace rsd::dds
