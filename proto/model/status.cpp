#include "rsd_model/status.hpp"

#include "read_json.hpp"

namespace rsd::model {


using namespace read_json;

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

DomainStatus domain_status_from_json(const nlohmann::json& doc) {
  constexpr const char* what = "a domain entry";
  want_object(doc, what);
  DomainStatus s;
  const auto& domain = member(doc, status_key::domain, what);
  if (!domain.is_number_integer() || domain.get<std::int64_t>() < 0 || domain.get<std::int64_t>() > 232)
    throw MalformedDocument("a domain entry's \"domain\" is not a domain id");
  s.domain = domain.get<int>();
  const auto state = text(doc, status_key::state, what);
  const auto parsed = parse_domain_state(state);
  if (!parsed) throw MalformedDocument("a domain entry has an unknown state '" + state + "'");
  s.state = *parsed;
  s.participant_guid = text(doc, status_key::participant_guid, what);
  s.error = text(doc, status_key::error, what);
  s.devices = count(doc, status_key::devices, what);
  s.accepted = count(doc, status_key::accepted, what);
  s.stopping = count(doc, status_key::stopping, what);
  const auto& rejected = member(doc, status_key::rejected, what);
  if (!rejected.is_object()) throw MalformedDocument("a domain entry's \"rejected\" is not an object");
  for (const auto& [reason, n] : rejected.items()) s.rejected[reason] = count_value(n, reason, what);
  s.rebuilds = count(doc, status_key::rebuilds, what);
  s.refreshes = count(doc, status_key::refreshes, what);
  s.lost_servers = count(doc, status_key::lost_servers, what);
  // A daemon from before the writer caps leaves them out.
  if (doc.contains(status_key::writers)) s.writers = count(doc, status_key::writers, what);
  if (const auto it = doc.find(status_key::writers_refused); it != doc.end()) {
    if (!it->is_object()) throw MalformedDocument("a domain entry's \"writers-refused\" is not an object");
    for (const auto& [reason, n] : it->items()) s.writers_refused[reason] = count_value(n, reason, what);
  }
  // A daemon from before the endpoint caps leaves them out.
  if (const auto it = doc.find(status_key::endpoints_refused); it != doc.end()) {
    if (!it->is_object()) throw MalformedDocument("a domain entry's \"endpoints-refused\" is not an object");
    for (const auto& [reason, n] : it->items()) s.endpoints_refused[reason] = count_value(n, reason, what);
  }
  // A daemon from before it followed the host's network leaves them out.
  if (const auto it = doc.find(status_key::interfaces); it != doc.end()) {
    if (!it->is_array()) throw MalformedDocument("a domain entry's \"interfaces\" is not a list");
    for (const auto& i : *it) {
      want_object(i, "an interface");
      InterfaceStatus entry;
      entry.name = text(i, status_key::name, "an interface");
      const auto& addresses = member(i, status_key::addresses, "an interface");
      if (!addresses.is_array()) throw MalformedDocument("an interface's \"addresses\" is not a list");
      for (const auto& a : addresses) {
        if (!a.is_string()) throw MalformedDocument("an interface address is not a string");
        entry.addresses.push_back(a.get<std::string>());
      }
      s.interfaces.push_back(std::move(entry));
    }
  }
  if (doc.contains(status_key::network_changes)) s.network_changes = count(doc, status_key::network_changes, what);
  if (doc.contains(status_key::network_changed_at)) s.network_changed_at = text(doc, status_key::network_changed_at, what);
  s.complete = flag(doc, status_key::complete, what);
  return s;
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

Health health_from_json(const nlohmann::json& doc) {
  constexpr const char* what = "/healthz";
  want_object(doc, what);
  Health h;
  h.status = text(doc, status_key::status, what);
  h.version = text(doc, status_key::version, what);
  h.devices = count(doc, status_key::devices, what);
  h.generation = count(doc, status_key::generation, what);
  h.complete = flag(doc, status_key::complete, what);
  const auto& usb = member(doc, status_key::usb, what);
  want_object(usb, "/healthz \"usb\"");
  h.usb.state = text(usb, status_key::state, what);
  if (usb.contains(status_key::devices)) h.usb.devices = count(usb, status_key::devices, what);
  if (usb.contains(status_key::error)) h.usb.error = text(usb, status_key::error, what);
  if (doc.contains(status_key::http)) {  // older daemons leave it out
    const auto& http = member(doc, status_key::http, what);
    want_object(http, "/healthz \"http\"");
    HttpHealth out;
    out.listening = text(http, status_key::listening, what);
    out.configured = text(http, status_key::configured, what);
    out.from = text(http, status_key::from, what);
    out.agrees = flag(http, status_key::agrees, what);
    h.http = out;
  }
  if (doc.contains(status_key::expected)) h.expected = expected_report_from_json(doc[status_key::expected]);
  return h;
}

}  // namespace rsd::model
