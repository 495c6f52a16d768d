// Logging to stderr with syslog priority prefixes ("<6>..."), which journald
// turns into real priorities when the daemon runs as a service; on a terminal,
// with the local time and the level's word instead ("... 08:50:01.123 info: ..."). Thread-safe: DDS
// listener threads, the libusb thread and API workers all log.
#pragma once

#include <chrono>
#include <concepts>
#include <cstdio>
#include <mutex>
#include <string>
#include <string_view>
#include <unordered_map>

namespace rsd::log {

enum class Level { error = 3, warning = 4, notice = 5, info = 6, debug = 7 };

// "error", "warning", "notice", "info", "debug"; false when the name is unknown.
bool parse_level(std::string_view name, Level& out);
void set_level(Level level);
bool enabled(Level level);
void write(Level level, std::string_view message);

inline void error(std::string_view m) { write(Level::error, m); }
inline void warning(std::string_view m) { write(Level::warning, m); }
inline void notice(std::string_view m) { write(Level::notice, m); }
inline void info(std::string_view m) { write(Level::info, m); }
inline void debug(std::string_view m) { write(Level::debug, m); }

// The lazy forms: `make` (a lambda returning the message) runs only when the
// level is on, so a line on a hot path costs one atomic load while it is off.
// Use them where the message is built for every request, message or device:
//   log::debug([&] { return "api: " + req.method + " " + req.target; });
template <class Make>
  requires std::invocable<Make&>
void write(Level level, Make&& make) {
  if (enabled(level)) write(level, std::string_view(make()));
}
template <class Make>
  requires std::invocable<Make&>
void info(Make&& make) {
  write(Level::info, make);
}
template <class Make>
  requires std::invocable<Make&>
void debug(Make&& make) {
  write(Level::debug, make);
}

// "domain 5: ", the start of every line about one DDS domain, spelled once.
inline std::string domain_prefix(int domain) { return "domain " + std::to_string(domain) + ": "; }

// Lets one line per key through per interval and counts what it held back, so a
// peer flooding bad messages cannot flood the journal; the next line that gets
// through says how many were suppressed.
class RateLimiter {
 public:
  explicit RateLimiter(std::chrono::milliseconds interval = std::chrono::seconds(10))
      : interval_(interval) {}
  // Returns true when a line for `key` may be written now; `suppressed` is set to
  // the number of lines held back for that key since the last one written.
  bool allow(const std::string& key, std::uint64_t& suppressed);

 private:
  struct Slot {
    std::chrono::steady_clock::time_point last{};
    std::uint64_t suppressed = 0;
    bool used = false;
  };
  std::chrono::milliseconds interval_;
  std::mutex mutex_;
  std::unordered_map<std::string, Slot> slots_;
};

}  // namespace rsd::log
