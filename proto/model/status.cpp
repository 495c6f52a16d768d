// The status documents written (rsd_model/status.hpp).
#include "rsd_model/status.hpp"

namespace rsd::model {


nlohmann::json to_json(const DomainStatus& s) {
  nlohmann::json rejected = nlohmann::json::object();
  for (const auto& [reason, n] : s.rejected) rejected[reason] = n;
  nlohmann::json refused = nlohmann::json::object();
  for (const auto& [reason, n] : s.writers_refused) refused[reason] = n;
  nlohmann::json endpoints_refused = nlohmann::json::object();
  for (const auto& [reason, n] : s.endpoints_refused) endpoints_refused[reason] = n;
  nlohmann::json interfaces = nlohmann::json::array();
  for (const auto& i : s.interfaces) interfaces.push_back({{status_key::name, i.name}, {status_key::addresses, i.addresses}});
  return {{status_key::domain, s.domain},
          {status_key::state, to_string(s.state)},
          {status_key::participant_guid, s.participant_guid},
          {status_key::error, s.error},
          {status_key::devices, s.devices},
          {status_key::accepted, s.accepted},
          {status_key::stopping, s.stopping},
          {status_key::rejected, std::move(rejected)},
          {status_key::rebuilds, s.rebuilds},
          {status_key::refreshes, s.refreshes},
          {status_key::lost_servers, s.lost_servers},
          {status_key::writers, s.writers},
          {status_key::writers_refused, std::move(refused)},
          {status_key::endpoints_refused, std::move(endpoints_refused)},
          {status_key::interfaces, std::move(interfaces)},
          {status_key::network_changes, s.network_changes},
          {status_key::network_changed_at, s.network_changed_at},
          {status_key::complete, s.complete}};
}

nlohmann::json to_json(const Health& h) {
  nlohmann::json usb = {{status_key::state, h.usb.state}};
  if (h.usb.devices) usb[status_key::devices] = *h.usb.devices;
  if (h.usb.error) usb[status_key::error] = *h.usb.error;
  nlohmann::json doc = {{status_key::status, h.status},         {status_key::version, h.version},   {status_key::devices, h.devices},
                        {status_key::generation, h.generation}, {status_key::complete, h.complete}, {status_key::usb, std::move(usb)}};
  if (h.http)
    doc[status_key::http] = {{status_key::listening, h.http->listening},
                      {status_key::configured, h.http->configured},
                      {status_key::from, h.http->from},
                      {status_key::agrees, h.http->agrees}};
  if (h.expected) doc[status_key::expected] = to_json(*h.expected);
  return doc;
}

}  // namespace rsd::model
