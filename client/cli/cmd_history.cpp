// rs-discover history: when and why cameras came and went (one camera's, or all).
#include "common.hpp"

#include <nlohmann/json.hpp>

namespace rsdiscover {
namespace {

void change_row(const nlohmann::json& c, bool with_id) {
  const std::string event = c.value("event", "");
  std::string what = event;
  if (event == "added") what = c.value("arrival", "") == "back" ? "back" : "added";
  if (event == "removed") what = "removed: " + c.value("reason", "?");
  std::printf("%-26s %s%s\n", c.value("at", "").c_str(), with_id ? (c.value("id", "") + "  ").c_str() : "",
              paint(what, event == "removed" ? color::red : color::green).c_str());
}

int run(const ParsedArgs& args) {
  if (args.positional.size() > 1) throw UsageError("give at most one device ID");
  auto client = make_client(args);
  if (args.positional.empty()) {
    const auto doc = nlohmann::json::parse(client.history(0), nullptr, false);
    if (!doc.is_object()) throw rsdiscovery::Error(rsdiscovery::ErrorCode::malformed_reply, "history is not JSON");
    if (args.has("json")) {
      std::printf("%s\n", doc.dump(output().color ? 2 : -1).c_str());
      return kOk;
    }
    const nlohmann::json changes = doc.value("changes", nlohmann::json::array());
    for (const auto& c : changes) change_row(c, true);
    return kOk;
  }
  const auto doc = nlohmann::json::parse(client.device_history(args.positional[0]), nullptr, false);
  if (!doc.is_object()) throw rsdiscovery::Error(rsdiscovery::ErrorCode::malformed_reply, "history is not JSON");
  if (args.has("json")) {
    std::printf("%s\n", doc.dump(output().color ? 2 : -1).c_str());
    return kOk;
  }
  const std::string state = doc.value("state", "");
  std::printf("%s: %s\n", doc.value("id", "").c_str(), paint(state, state == "gone" ? color::red : color::green).c_str());
  if (doc.contains("gone") && doc["gone"].is_object()) {
    const auto& g = doc["gone"];
    std::printf("  gone since %s (%s), last seen %s\n", g.value("removed-at", "").c_str(),
                g.value("reason", "").c_str(), g.value("last-seen", "").c_str());
    if (g.contains("detail")) std::printf("  %s\n", g.value("detail", "").c_str());
  }
  std::string counts;
  const nlohmann::json removals = doc.value("removals", nlohmann::json::object());
  for (const auto& [reason, n] : removals.items())
    if (n.is_number_unsigned() && n.get<std::uint64_t>() > 0) counts += " " + reason + "=" + std::to_string(n.get<std::uint64_t>());
  if (!counts.empty()) std::printf("  removals:%s\n", counts.c_str());
  const nlohmann::json changes = doc.value("changes", nlohmann::json::array());
  for (const auto& c : changes) change_row(c, false);
  return kOk;
}

}  // namespace

const Command kHistoryCommand = {
    "history",
    "when and why cameras came and went",
    "history [ID] [--json]",
    "Print a camera's history (by id, serial or topic-root, present or gone): whether it\n"
    "is here or gone and why, its removals by reason and its latest changes. Without an\n"
    "ID, every camera's changes in order. The exit status is 1 for a camera never seen.",
    {
        {"json", 'j', nullptr, "print the daemon's JSON"},
    },
    run,
};

}  // namespace rsdiscover
