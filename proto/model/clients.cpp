// A camera's clients and its in-use summary as JSON, both ways (rsd_model/clients.hpp).
#include "rsd_model/clients.hpp"

#include "peer_json.hpp"
#include "read_json.hpp"

namespace rsd::model {

namespace {

namespace ckey {
constexpr const char* clients = "clients";
constexpr const char* streams = "streams";
constexpr const char* since = "since";
constexpr const char* ros_nodes = "ros-nodes";
}  // namespace ckey

constexpr const char* kClient = "a client entry";
constexpr const char* kClients = "a device's clients";

Client client_from_json(const nlohmann::json& doc) {
  using namespace read_json;
  want_object(doc, kClient);
  Client c;
  peer_json::read(doc, c, kClient);
  c.since = text(doc, ckey::since, kClient);
  c.streams = texts(doc, ckey::streams, kClient);
  // Absent from daemons before it.
  if (doc.contains(ckey::ros_nodes)) c.ros_nodes = texts(doc, ckey::ros_nodes, kClient);
  return c;
}

}  // namespace

InUse summary_of(const DeviceClients& c) {
  InUse u;
  u.clients = c.clients.size();
  for (const auto& [stream, readers] : c.streams)
    if (readers > 0) u.streaming.push_back(stream);
  return u;
}

nlohmann::json to_json(const Client& c) {
  nlohmann::json doc = {{ckey::since, c.since}, {ckey::streams, c.streams}, {ckey::ros_nodes, c.ros_nodes}};
  peer_json::write(doc, c);
  return doc;
}

nlohmann::json to_json(const DeviceClients& c) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& client : c.clients) list.push_back(to_json(client));
  nlohmann::json streams = nlohmann::json::object();
  for (const auto& [name, readers] : c.streams) streams[name] = readers;
  return {{ckey::clients, std::move(list)}, {ckey::streams, std::move(streams)}};
}

DeviceClients device_clients_from_json(const nlohmann::json& doc) {
  using namespace read_json;
  want_object(doc, kClients);
  DeviceClients out;
  const auto& list = member(doc, ckey::clients, kClients);
  if (!list.is_array()) throw MalformedDocument(std::string(kClients) + ": \"clients\" is not an array");
  for (const auto& c : list) out.clients.push_back(client_from_json(c));
  const auto& streams = member(doc, ckey::streams, kClients);
  if (!streams.is_object()) throw MalformedDocument(std::string(kClients) + ": \"streams\" is not an object");
  for (const auto& [name, readers] : streams.items()) out.streams[name] = count_value(readers, name, kClients);
  return out;
}

}  // namespace rsd::model
