#include "log/log.hpp"

#include <sys/stat.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <ctime>

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

namespace {
// How a line starts, chosen once from where stderr goes. The journal (systemd sets
// JOURNAL_STREAM to stderr's device:inode) reads "<N>" as the priority and stamps
// the time itself; everywhere else (a terminal, a file, `docker logs`' pipe) a
// person reads the line: the local time and the level's word.
enum class Form { priority, readable };

Form detect_form() {
  if (const char* stream = std::getenv("JOURNAL_STREAM")) {
    unsigned long long dev = 0, ino = 0;
    struct stat st {};
    if (std::sscanf(stream, "%llu:%llu", &dev, &ino) == 2 && fstat(STDERR_FILENO, &st) == 0 &&
        static_cast<unsigned long long>(st.st_dev) == dev && static_cast<unsigned long long>(st.st_ino) == ino)
      return Form::priority;
  }
  return Form::readable;
}

const char* level_word(Level level) {
  switch (level) {
    case Level::error: return "error";
    case Level::warning: return "warning";
    case Level::notice: return "notice";
    case Level::info: return "info";
    case Level::debug: return "debug";
  }
  return "?";
}

// "2026-12-02 08:50:01.123 notice: " in local time.
std::string readable_prefix(Level level) {
  timeval tv{};
  gettimeofday(&tv, nullptr);
  std::tm tm{};
  localtime_r(&tv.tv_sec, &tm);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02d %02d:%02d:%02d.%03d %s: ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(tv.tv_usec / 1000), level_word(level));
  return buf;
}
}  // namespace

void write(Level level, std::string_view message) {
  if (!enabled(level)) return;
  static const Form form = detect_form();
  std::string line = form == Form::readable ? readable_prefix(level)
                                            : "<" + std::to_string(static_cast<int>(level)) + ">";
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
