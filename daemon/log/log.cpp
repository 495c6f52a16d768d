#include "log/log.hpp"

#include <atomic>

namespace rsd::log {
namespace {
std::atomic<int> g_level{static_cast<int>(Level::info)};
std::mutex g_write_mutex;
}  // namespace

bool parse_level(std::string_view name, Level& out) {
  static constexpr std::pair<std::string_view, Level> kNames[] = {
      {"error", Level::error}, {"warning", Level::warning}, {"notice", Level::notice},
      {"info", Level::info},   {"debug", Level::debug}};
  for (const auto& [n, l] : kNames)
    if (n == name) {
      out = l;
      return true;
    }
  return false;
}

void set_level(Level level) { g_level = static_cast<int>(level); }
bool enabled(Level level) { return static_cast<int>(level) <= g_level.load(); }

void write(Level level, std::string_view message) {
  if (!enabled(level)) return;
  std::string line = "<" + std::to_string(static_cast<int>(level)) + ">";
  // One line per message: a stray newline from a peer's data would forge a new
  // journal entry with a priority of the peer's choosing.
  for (char c : message) line += (c == '\n' || c == '\r') ? ' ' : c;
  line += '\n';
  std::lock_guard lock(g_write_mutex);
  std::fwrite(line.data(), 1, line.size(), stderr);
  std::fflush(stderr);
}

bool RateLimiter::allow(const std::string& key, std::uint64_t& suppressed) {
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard lock(mutex_);
  Slot& slot = slots_[key];
  if (slot.used && now - slot.last < interval_) {
    ++slot.suppressed;
    return false;
  }
  suppressed = slot.suppressed;
  slot = Slot{now, 0, true};
  return true;
}

}  // namespace rsd::log
