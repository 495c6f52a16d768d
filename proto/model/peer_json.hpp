// A DDS peer's identity as the API writes it, in a participant entry and in a camera's
// client alike: one spelling of its keys and one reader and writer of them, for any
// type with those members (Participant, Client). Internal to rsd_model.
#pragma once

#include "read_json.hpp"
#include "rsd_model/participant.hpp"  // Vendor, to_string, parse_vendor

#include <nlohmann/json.hpp>

namespace rsd::model::peer_json {


template <class Peer>
void write(nlohmann::json& doc, const Peer& p) {
  doc[peer_key::guid] = p.guid;
  doc[peer_key::name] = p.name;
  doc[peer_key::vendor] = to_string(p.vendor);
  doc[peer_key::vendor_id] = p.vendor_id;
  doc[peer_key::addresses] = p.addresses;
  // Only where the peer says them (Cyclone DDS peers do).
  if (p.host) doc[peer_key::host] = *p.host;
  if (p.process) doc[peer_key::process] = *p.process;
  if (p.pid) doc[peer_key::pid] = *p.pid;
}

template <class Peer>
void read(const nlohmann::json& doc, Peer& p, const char* what) {
  using namespace read_json;
  p.guid = text(doc, peer_key::guid, what);
  p.name = text(doc, peer_key::name, what);
  // A vendor this client does not know yet (a newer daemon's) reads as "other".
  p.vendor = parse_vendor(text(doc, peer_key::vendor, what)).value_or(Vendor::other);
  p.vendor_id = text(doc, peer_key::vendor_id, what);
  p.addresses = texts(doc, peer_key::addresses, what);
  if (doc.contains(peer_key::host)) p.host = text(doc, peer_key::host, what);
  if (doc.contains(peer_key::process)) p.process = text(doc, peer_key::process, what);
  p.pid = read_json::pid(doc, peer_key::pid, what);
}

}  // namespace rsd::model::peer_json
