// The history routes: one camera's (GET /v1/devices/{id}/history, present or gone)
// and the whole table's (GET /v1/history?since=).
#include "api/handlers.hpp"
#include "api/history_format.hpp"

namespace rsd::api {

namespace {
constexpr std::size_t kDefaultHistoryLimit = 1000;
constexpr std::size_t kMaxHistoryLimit = 10000;
}  // namespace

void Handlers::handle_device_history(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/v1/devices/{id}/history", req.params, {})) return send_error(res, 400, *err);
  const auto history = table.history(req.id);
  if (!history) return send_error(res, 404, "no device with id '" + req.id + "' was ever seen (or it is forgotten)");
  const bool present = table.find_entry(history->id) != nullptr;
  send_json(res, 200, history_json(*history, present, present ? std::nullopt : table.find_gone(history->id)));
}

void Handlers::handle_history(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/v1/history", req.params, {"since", "limit"})) return send_error(res, 400, *err);
  std::uint64_t since = 0;
  if (req.has_param("since")) {
    const auto parsed = parse_generation(req.param("since"));
    if (!parsed) return send_error(res, 400, "bad since '" + req.param("since") + "': expected a generation");
    since = *parsed;
  }
  std::size_t limit = kDefaultHistoryLimit;
  if (req.has_param("limit")) {
    const auto parsed = parse_generation(req.param("limit"));
    if (!parsed || *parsed == 0 || *parsed > kMaxHistoryLimit)
      return send_error(res, 400, "bad limit '" + req.param("limit") + "': expected 1 to " +
                                      std::to_string(kMaxHistoryLimit));
    limit = static_cast<std::size_t>(*parsed);
  }
  const std::uint64_t generation = table.generation();
  const auto changes = table.history_since(since, limit);
  nlohmann::json list = nlohmann::json::array();
  for (const auto& c : changes) list.push_back(to_json(c));
  // `next`: the since of the following page (the last change's generation), or the
  // table's generation when this page holds all there is.
  const std::uint64_t next = changes.size() == limit ? changes.back().generation : std::max(since, generation);
  send_json(res, 200, {{model::key::changes, std::move(list)}, {model::key::generation, generation}, {model::key::next, next}});
}

}  // namespace rsd::api
