// The API's documents about cameras' comings and goings, pure: a device event's
// document as the stream sends it (with why it left, or whether it is back), a
// camera's history, the whole table's history and a gone camera's answer.
#pragma once

#include "table/device_table.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace rsd::api {

// The entry's text, plus "reason" on a removal the table knows the reason of, and
// "arrival" ("new" or "back", with "away-since") on a table's own addition.
// `sent_as`: the type the client sees (a filter turns a change into either).
std::string event_document(const DeviceEvent& event, EventType sent_as);

nlohmann::json to_json(const HistoryRecord& change);
// GET /v1/devices/{key}/history: the camera's state (present, else gone, with its gone
// entry while the table keeps it), its changes and its removals by reason (every
// reason, 0 included).
nlohmann::json history_json(const CameraHistory& history, bool present, const std::optional<GoneEntry>& gone);
// GET /v1/devices/{key} of a camera that left: 410 Gone with this body.
nlohmann::json gone_json(const GoneEntry& gone);

}  // namespace rsd::api
