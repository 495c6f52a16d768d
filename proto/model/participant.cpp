#include "rsd_model/participant.hpp"

#include "peer_json.hpp"
#include "read_json.hpp"

namespace rsd::model {

namespace {


constexpr const char* kWhat = "a participant entry";

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

std::string vendor_id_of(std::string_view guid) {
  if (guid.size() < 4) return "";
  for (std::size_t i = 0; i < 4; ++i)
    if (hex_digit(guid[i]) < 0) return "";
  std::string out;
  out += guid.substr(0, 2);
  out += '.';
  out += guid.substr(2, 2);
  return out;
}

Vendor vendor_of(std::string_view vendor_id) {
  // The OMG's vendor id registry (https://www.dds-foundation.org/dds-rtps-vendor-and-product-ids/).
  if (vendor_id == "01.0f") return Vendor::fast_dds;
  if (vendor_id == "01.10") return Vendor::cyclone_dds;
  if (vendor_id == "01.01") return Vendor::rti_connext;
  if (vendor_id == "01.03") return Vendor::opendds;
  return Vendor::other;
}

nlohmann::json to_json(const Participant& p) {
  nlohmann::json doc = {{participant_key::domain, p.domain},
                        {participant_key::state, to_string(p.state)},
                        {participant_key::first_seen, p.first_seen},
                        {participant_key::last_seen, p.last_seen},
                        {participant_key::device_info_writers, p.device_info_writers},
                        {participant_key::devices, p.devices},
                        {participant_key::silent_writers, p.silent_writers},
                        {participant_key::never_announced, p.never_announced},
                        {participant_key::topic_roots, p.topic_roots},
                        {participant_key::endpoints, p.endpoints}};
  peer_json::write(doc, p);
  if (p.lease_seconds) doc[participant_key::lease_seconds] = *p.lease_seconds;
  return doc;
}

Participant participant_from_json(const nlohmann::json& doc) {
  using namespace read_json;
  want_object(doc, kWhat);
  Participant p;
  const auto& domain = member(doc, participant_key::domain, kWhat);
  if (!domain.is_number_integer() || domain.get<std::int64_t>() < 0 || domain.get<std::int64_t>() > 232)
    throw MalformedDocument("a participant entry's \"domain\" is not a domain id");
  p.domain = domain.get<int>();
  peer_json::read(doc, p, kWhat);
  if (auto it = doc.find(participant_key::lease_seconds); it != doc.end()) {
    if (!it->is_number()) throw MalformedDocument("a participant entry's \"lease-seconds\" is not a number");
    p.lease_seconds = it->get<double>();
  }
  const auto state = text(doc, participant_key::state, kWhat);
  const auto parsed = parse_participant_state(state);
  if (!parsed) throw MalformedDocument("a participant entry has an unknown state '" + state + "'");
  p.state = *parsed;
  p.first_seen = text(doc, participant_key::first_seen, kWhat);
  p.last_seen = text(doc, participant_key::last_seen, kWhat);
  p.device_info_writers = count(doc, participant_key::device_info_writers, kWhat);
  p.devices = count(doc, participant_key::devices, kWhat);
  p.silent_writers = count(doc, participant_key::silent_writers, kWhat);
  p.never_announced = flag(doc, participant_key::never_announced, kWhat);
  p.topic_roots = texts(doc, participant_key::topic_roots, kWhat);
  p.endpoints = count(doc, participant_key::endpoints, kWhat);
  return p;
}

}  // namespace rsd::model
