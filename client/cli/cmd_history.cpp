// rs-discover history: when and why cameras came and went (one camera's, or all).
#include "common.hpp"


namespace rsdiscover {
namespace {

using rsdiscovery::json::find;
using rsdiscovery::json::text_or;

void change_row(const rsdiscovery::json::Value& c, bool with_id) {
  const std::string event = text_or(find(c, "event"));
  std::string what = event;
  if (event == "added") what = text_or(find(c, "arrival")) == "back" ? "back" : "added";
  if (event == "removed") what = "removed: " + text_or(find(c, "reason"), "?");
  std::printf("%-26s %s%s\n", text_or(find(c, "at")).c_str(), with_id ? (text_or(find(c, "id")) + "  ").c_str() : "",
              paint(what, event == "removed" ? color::red : color::green).c_str());
}

// Each change of the document's "changes", in order.
void change_rows(const rsdiscovery::json::Value& doc, bool with_id) {
  const auto* changes = find(doc, "changes");
  if (changes && changes->IsArray())
    for (const auto& c : changes->GetArray()) change_row(c, with_id);
}

int run(const ParsedArgs& args) {
  if (args.positional.size() > 1) throw UsageError("give at most one device ID");
  auto client = make_client(args);
  const std::string history =
      args.positional.empty() ? client.history(0) : client.device_history(args.positional[0]);
  const auto doc = rsdiscovery::json::parse_or_null(history);
  if (!doc.IsObject()) throw rsdiscovery::Error(rsdiscovery::ErrorCode::malformed_reply, "history is not JSON");
  if (args.has("json")) {
    std::printf("%s\n", rsdiscovery::json::dump(doc, output().color ? 2 : -1).c_str());
    return kOk;
  }
  if (args.positional.empty()) {
    change_rows(doc, true);
    return kOk;
  }
  const std::string state = text_or(find(doc, "state"));
  std::printf("%s: %s\n", text_or(find(doc, "id")).c_str(),
              paint(state, state == "gone" ? color::red : color::green).c_str());
  if (const auto* g = find(doc, "gone"); g && g->IsObject()) {
    std::printf("  gone since %s (%s), last seen %s\n", text_or(find(g, "removed-at")).c_str(),
                text_or(find(g, "reason")).c_str(), text_or(find(g, "last-seen")).c_str());
    if (find(g, "detail")) std::printf("  %s\n", text_or(find(g, "detail")).c_str());
  }
  std::string counts;
  if (const auto* removals = find(doc, "removals"); removals && removals->IsObject())
    for (const auto& [reason, n] : removals->GetObject())
      if (n.IsUint64() && n.GetUint64() > 0)
        counts += " " + std::string(reason.GetString(), reason.GetStringLength()) + "=" + std::to_string(n.GetUint64());
  if (!counts.empty()) std::printf("  removals:%s\n", counts.c_str());
  change_rows(doc, false);
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
