// A camera's clients and its in-use summary written (rsd_model/clients.hpp).
#include "rsd_model/clients.hpp"

#include "peer_json.hpp"

namespace rsd::model {

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

}  // namespace rsd::model
