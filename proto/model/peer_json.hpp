// A DDS peer's identity as the API writes it, in a participant entry and in a camera's
// client alike: one spelling of its keys and one reader and writer of them, for any
// type with those members (Participant, Client). Internal to rsd_model.
#pragma once

#include "read_json.hpp"
#include "rsd_model/participant.hpp"  // Vendor, to_string, parse_vendor

#include <nlohmann/json.hpp>

namespace rsd::model::peer_json {

namespace key {
inline constexpr const char* guid = "guid";
inline constexpr const char* name = "name";
inline constexpr const char* vendor = "vendor";
inline constexpr const char* vendor_id = "vendor-id";
inline constexpr const char* addresses = "addresses";
inline constexpr const char* host = "host";
inline constexpr const char* process = "process";
inline constexpr const char* pid = "pid";
}  // namespace key

template <class Peer>
void write(nlohmann::json& doc, const Peer& p) {
  doc[key::guid] = p.guid;
  doc[key::name] = p.name;
  doc[key::vendor] = to_string(p.vendor);
  doc[key::vendor_id] = p.vendor_id;
  doc[key::addresses] = p.addresses;
  // Only where the peer says them (Cyclone DDS peers do).
  if (p.host) doc[key::host] = *p.host;
  if (p.process) doc[key::process] = *p.process;
  if (p.pid) doc[key::pid] = *p.pid;
}

template <class Peer>
void read(const nlohmann::json& doc, Peer& p, const char* what) {
  using namespace read_json;
  p.guid = text(doc, key::guid, what);
  p.name = text(doc, key::name, what);
  // A vendor this client does not know yet (a newer daemon's) reads as "other".
  p.vendor = parse_vendor(text(doc, key::vendor, what)).value_or(Vendor::other);
  p.vendor_id = text(doc, key::vendor_id, what);
  p.addresses = texts(doc, key::addresses, what);
  if (doc.contains(key::host)) p.host = text(doc, key::host, what);
  if (doc.contains(key::process)) p.process = text(doc, key::process, what);
  p.pid = read_json::pid(doc, key::pid, what);
}

}  // namespace rsd::model::peer_json
