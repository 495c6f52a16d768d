#include "rsd_model/status.hpp"

#include "read_json.hpp"

namespace rsd::model {

namespace {

// Every key of the two documents: nothing else spells them.
namespace key {
constexpr const char* domain = "domain";
constexpr const char* state = "state";
constexpr const char* participant_guid = "participant-guid";
constexpr const char* error = "error";
constexpr const char* devices = "devices";
constexpr const char* accepted = "accepted";
constexpr const char* stopping = "stopping";
constexpr const char* rejected = "rejected";
constexpr const char* rebuilds = "rebuilds";
constexpr const char* refreshes = "refreshes";
constexpr const char* lost_servers = "lost-servers";
constexpr const char* writers = "device-info-writers";
constexpr const char* writers_refused = "writers-refused";
constexpr const char* endpoints_refused = "endpoints-refused";
constexpr const char* interfaces = "interfaces";
constexpr const char* name = "name";
constexpr const char* addresses = "addresses";
constexpr const char* network_changes = "network-changes";
constexpr const char* network_changed_at = "network-changed-at";
constexpr const char* complete = "complete";
constexpr const char* status = "status";
constexpr const char* version = "version";
constexpr const char* generation = "generation";
constexpr const char* usb = "usb";
constexpr const char* http = "http";
constexpr const char* listening = "listening";
constexpr const char* configured = "configured";
constexpr const char* from = "from";
constexpr const char* agrees = "agrees";
constexpr const char* expected = "expected";
}  // namespace key

}  // namespace

using namespace read_json;

nlohmann::json to_json(const DomainStatus& s) {
  nlohmann::json rejected = nlohmann::json::object();
  for (const auto& [reason, n] : s.rejected) rejected[reason] = n;
  nlohmann::json refused = nlohmann::json::object();
  for (const auto& [reason, n] : s.writers_refused) refused[reason] = n;
  nlohmann::json endpoints_refused = nlohmann::json::object();
  for (const auto& [reason, n] : s.endpoints_refused) endpoints_refused[reason] = n;
  nlohmann::json interfaces = nlohmann::json::array();
  for (const auto& i : s.interfaces) interfaces.push_back({{key::name, i.name}, {key::addresses, i.addresses}});
  return {{key::domain, s.domain},
          {key::state, to_string(s.state)},
          {key::participant_guid, s.participant_guid},
          {key::error, s.error},
          {key::devices, s.devices},
          {key::accepted, s.accepted},
          {key::stopping, s.stopping},
          {key::rejected, std::move(rejected)},
          {key::rebuilds, s.rebuilds},
          {key::refreshes, s.refreshes},
          {key::lost_servers, s.lost_servers},
          {key::writers, s.writers},
          {key::writers_refused, std::move(refused)},
          {key::endpoints_refused, std::move(endpoints_refused)},
          {key::interfaces, std::move(interfaces)},
          {key::network_changes, s.network_changes},
          {key::network_changed_at, s.network_changed_at},
          {key::complete, s.complete}};
}

DomainStatus domain_status_from_json(const nlohmann::json& doc) {
  constexpr const char* what = "a domain entry";
  want_object(doc, what);
  DomainStatus s;
  const auto& domain = member(doc, key::domain, what);
  if (!domain.is_number_integer() || domain.get<std::int64_t>() < 0 || domain.get<std::int64_t>() > 232)
    throw MalformedDocument("a domain entry's \"domain\" is not a domain id");
  s.domain = domain.get<int>();
  const auto state = text(doc, key::state, what);
  const auto parsed = parse_domain_state(state);
  if (!parsed) throw MalformedDocument("a domain entry has an unknown state '" + state + "'");
  s.state = *parsed;
  s.participant_guid = text(doc, key::participant_guid, what);
  s.error = text(doc, key::error, what);
  s.devices = count(doc, key::devices, what);
  s.accepted = count(doc, key::accepted, what);
  s.stopping = count(doc, key::stopping, what);
  const auto& rejected = member(doc, key::rejected, what);
  if (!rejected.is_object()) throw MalformedDocument("a domain entry's \"rejected\" is not an object");
  for (const auto& [reason, n] : rejected.items()) s.rejected[reason] = count_value(n, reason, what);
  s.rebuilds = count(doc, key::rebuilds, what);
  s.refreshes = count(doc, key::refreshes, what);
  s.lost_servers = count(doc, key::lost_servers, what);
  // A daemon from before the writer caps leaves them out.
  if (doc.contains(key::writers)) s.writers = count(doc, key::writers, what);
  if (const auto it = doc.find(key::writers_refused); it != doc.end()) {
    if (!it->is_object()) throw MalformedDocument("a domain entry's \"writers-refused\" is not an object");
    for (const auto& [reason, n] : it->items()) s.writers_refused[reason] = count_value(n, reason, what);
  }
  // A daemon from before the endpoint caps leaves them out.
  if (const auto it = doc.find(key::endpoints_refused); it != doc.end()) {
    if (!it->is_object()) throw MalformedDocument("a domain entry's \"endpoints-refused\" is not an object");
    for (const auto& [reason, n] : it->items()) s.endpoints_refused[reason] = count_value(n, reason, what);
  }
  // A daemon from before it followed the host's network leaves them out.
  if (const auto it = doc.find(key::interfaces); it != doc.end()) {
    if (!it->is_array()) throw MalformedDocument("a domain entry's \"interfaces\" is not a list");
    for (const auto& i : *it) {
      want_object(i, "an interface");
      InterfaceStatus entry;
      entry.name = text(i, key::name, "an interface");
      const auto& addresses = member(i, key::addresses, "an interface");
      if (!addresses.is_array()) throw MalformedDocument("an interface's \"addresses\" is not a list");
      for (const auto& a : addresses) {
        if (!a.is_string()) throw MalformedDocument("an interface address is not a string");
        entry.addresses.push_back(a.get<std::string>());
      }
      s.interfaces.push_back(std::move(entry));
    }
  }
  if (doc.contains(key::network_changes)) s.network_changes = count(doc, key::network_changes, what);
  if (doc.contains(key::network_changed_at)) s.network_changed_at = text(doc, key::network_changed_at, what);
  s.complete = flag(doc, key::complete, what);
  return s;
}

nlohmann::json to_json(const Health& h) {
  nlohmann::json usb = {{key::state, h.usb.state}};
  if (h.usb.devices) usb[key::devices] = *h.usb.devices;
  if (h.usb.error) usb[key::error] = *h.usb.error;
  nlohmann::json doc = {{key::status, h.status},         {key::version, h.version},   {key::devices, h.devices},
                        {key::generation, h.generation}, {key::complete, h.complete}, {key::usb, std::move(usb)}};
  if (h.http)
    doc[key::http] = {{key::listening, h.http->listening},
                      {key::configured, h.http->configured},
                      {key::from, h.http->from},
                      {key::agrees, h.http->agrees}};
  if (h.expected) doc[key::expected] = to_json(*h.expected);
  return doc;
}

Health health_from_json(const nlohmann::json& doc) {
  constexpr const char* what = "/healthz";
  want_object(doc, what);
  Health h;
  h.status = text(doc, key::status, what);
  h.version = text(doc, key::version, what);
  h.devices = count(doc, key::devices, what);
  h.generation = count(doc, key::generation, what);
  h.complete = flag(doc, key::complete, what);
  const auto& usb = member(doc, key::usb, what);
  want_object(usb, "/healthz \"usb\"");
  h.usb.state = text(usb, key::state, what);
  if (usb.contains(key::devices)) h.usb.devices = count(usb, key::devices, what);
  if (usb.contains(key::error)) h.usb.error = text(usb, key::error, what);
  if (doc.contains(key::http)) {  // older daemons leave it out
    const auto& http = member(doc, key::http, what);
    want_object(http, "/healthz \"http\"");
    HttpHealth out;
    out.listening = text(http, key::listening, what);
    out.configured = text(http, key::configured, what);
    out.from = text(http, key::from, what);
    out.agrees = flag(http, key::agrees, what);
    h.http = out;
  }
  if (doc.contains(key::expected)) h.expected = expected_report_from_json(doc[key::expected]);
  return h;
}

}  // namespace rsd::model
