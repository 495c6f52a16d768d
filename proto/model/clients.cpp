// A camera's clients and its in-use summary as JSON, both ways (rsd_model/clients.hpp).
#include "rsd_model/clients.hpp"

#include "peer_json.hpp"
#include "read_json.hpp"

namespace rsd::model {

namespace {


constexpr const char* kClient = "a client entry";
constexpr const char* kClients = "a device's clients";

Client client_from_json(const nlohmann::json& doc) {
  using namespace read_json;
  want_object(doc, kClient);
  Client c;
  peer_json::read(doc, c, kClient);
  c.since = text(doc, clients_key::since, kClient);
  c.streams = texts(doc, clients_key::streams, kClient);
  // Absent from daemons before it.
  if (doc.contains(clients_key::ros_nodes)) c.ros_nodes = texts(doc, clients_key::ros_nodes, kClient);
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
  nlohmann::json doc = {{clients_key::since, c.since}, {clients_key::streams, c.streams}, {clients_key::ros_nodes, c.ros_nodes}};
  peer_json::write(doc, c);
  return doc;
}

nlohmann::json to_json(const DeviceClients& c) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& client : c.clients) list.push_back(to_json(client));
  nlohmann::json streams = nlohmann::json::object();
  for (const auto& [name, readers] : c.streams) streams[name] = readers;
  return {{clients_key::clients, std::move(list)}, {clients_key::streams, std::move(streams)}};
}

DeviceClients device_clients_from_json(const nlohmann::json& doc) {
  using namespace read_json;
  want_object(doc, kClients);
  DeviceClients out;
  const auto& list = member(doc, clients_key::clients, kClients);
  if (!list.is_array()) throw MalformedDocument(std::string(kClients) + ": \"clients\" is not an array");
  for (const auto& c : list) out.clients.push_back(client_from_json(c));
  const auto& streams = member(doc, clients_key::streams, kClients);
  if (!streams.is_object()) throw MalformedDocument(std::string(kClients) + ": \"streams\" is not an object");
  for (const auto& [name, readers] : streams.items()) out.streams[name] = count_value(readers, name, kClients);
  return out;
}

}  // namespace rsd::model
