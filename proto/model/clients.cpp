// A camera's clients and its in-use summary as JSON, both ways (rsd_model/clients.hpp).
#include "rsd_model/clients.hpp"

#include "read_json.hpp"

namespace rsd::model {

namespace {

namespace ckey {
constexpr const char* clients = "clients";
constexpr const char* streams = "streams";
constexpr const char* guid = "guid";
constexpr const char* name = "name";
constexpr const char* vendor = "vendor";
constexpr const char* vendor_id = "vendor-id";
constexpr const char* addresses = "addresses";
constexpr const char* host = "host";
constexpr const char* process = "process";
constexpr const char* pid = "pid";
constexpr const char* since = "since";
}  // namespace ckey

constexpr const char* kClient = "a client entry";
constexpr const char* kClients = "a device's clients";

Client client_from_json(const nlohmann::json& doc) {
  using namespace read_json;
  want_object(doc, kClient);
  Client c;
  c.guid = text(doc, ckey::guid, kClient);
  c.name = text(doc, ckey::name, kClient);
  c.vendor = parse_vendor(text(doc, ckey::vendor, kClient)).value_or(Vendor::other);
  c.vendor_id = text(doc, ckey::vendor_id, kClient);
  c.addresses = texts(doc, ckey::addresses, kClient);
  if (doc.contains(ckey::host)) c.host = text(doc, ckey::host, kClient);
  if (doc.contains(ckey::process)) c.process = text(doc, ckey::process, kClient);
  c.pid = pid(doc, ckey::pid, kClient);
  c.since = text(doc, ckey::since, kClient);
  c.streams = texts(doc, ckey::streams, kClient);
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
  nlohmann::json doc = {{ckey::guid, c.guid},           {ckey::name, c.name},
                        {ckey::vendor, to_string(c.vendor)}, {ckey::vendor_id, c.vendor_id},
                        {ckey::addresses, c.addresses}, {ckey::since, c.since},
                        {ckey::streams, c.streams}};
  if (c.host) doc[ckey::host] = *c.host;
  if (c.process) doc[ckey::process] = *c.process;
  if (c.pid) doc[ckey::pid] = *c.pid;
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
