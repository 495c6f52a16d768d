// The documents of history_format.hpp, spelled through the model's keys.
#include "api/history_format.hpp"

#include "api/format.hpp"
#include "rsd_model/removal.hpp"

namespace rsd::api {

namespace {
std::string splice(const std::string& text, const nlohmann::json& more) {
  if (text.size() < 2 || text.back() != '}') return text;
  std::string out = text.substr(0, text.size() - 1);
  for (const auto& [key, value] : more.items()) out += "," + nlohmann::json(key).dump() + ":" + dump(value);
  return out + "}";
}
}  // namespace

std::string event_document(const DeviceEvent& e, EventType sent_as) {
  if (sent_as == EventType::removed && e.type == EventType::removed && e.reason)
    return splice(e.entry->text, {{model::key::reason, model::to_string(*e.reason)}});
  if (sent_as == EventType::added && e.type == EventType::added) {
    nlohmann::json more = {{model::key::arrival, e.back ? model::kArrivalBack : model::kArrivalNew}};
    if (e.back) more[model::key::away_since] = e.away_since;
    return splice(e.entry->text, more);
  }
  return e.entry->text;
}

nlohmann::json to_json(const HistoryRecord& c) {
  nlohmann::json out = {{model::key::id, c.id},
                        {model::key::generation, c.generation},
                        {model::key::at, c.at},
                        {model::key::event, to_string(c.type)}};
  if (c.reason) out[model::key::reason] = model::to_string(*c.reason);
  if (c.type == EventType::added) out[model::key::arrival] = c.back ? model::kArrivalBack : model::kArrivalNew;
  if (c.flap) out[model::key::flap] = true;
  if (c.host) out[model::key::host_check] = model::to_string(*c.host);
  if (!c.detail.empty()) out[model::key::detail] = c.detail;
  return out;
}

nlohmann::json history_json(const CameraHistory& h, bool present, const std::optional<GoneEntry>& gone) {
  nlohmann::json changes = nlohmann::json::array();
  for (const auto& c : h.changes) changes.push_back(to_json(c));
  nlohmann::json removals = nlohmann::json::object();
  for (const auto r : model::kRemovalReasons) removals[std::string(model::to_string(r))] = h.removed(r);
  nlohmann::json out = {{model::key::id, h.id},
                        {model::key::state, present ? model::kStatePresent : model::kStateGone},
                        {model::key::changes, std::move(changes)},
                        {model::key::removals, std::move(removals)},
                        {model::key::flaps, h.flaps}};
  if (!present && gone) out[model::key::gone] = gone_json(*gone);
  return out;
}

nlohmann::json gone_json(const GoneEntry& g) {
  nlohmann::json out = {{model::key::id, g.last->device.id},
                        {model::key::state, model::kStateGone},
                        {model::key::reason, model::to_string(g.reason)},
                        {model::key::removed_at, g.removed_at},
                        {model::key::last_seen, g.last->device.last_seen.value_or("")},
                        {model::key::device, g.last->json()}};
  if (!g.detail.empty()) out[model::key::detail] = g.detail;
  if (g.host) out[model::key::host_check] = model::to_string(*g.host);
  return out;
}

}  // namespace rsd::api
