// A DDS peer's identity as the API writes it, in a participant entry and in a camera's
// client alike: one writer of its keys, for any type with those members (Participant,
// Client). Internal to rsd_model.
#pragma once

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

}  // namespace rsd::model::peer_json
