// A participant entry written, and the vendor read from a GUID (rsd_model/participant.hpp).
#include "rsd_model/participant.hpp"

#include "peer_json.hpp"

namespace rsd::model {

namespace {

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

}  // namespace rsd::model
