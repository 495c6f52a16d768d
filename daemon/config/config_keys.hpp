// The daemon's configuration keys, each spelled once: its file key, its flag, how
// the file's JSON value and the flag's text set it, how two Configs compare on it,
// and whether a reload (SIGHUP) applies it. The file parser, the flag parser, the
// unknown-key message and the reload's restart-only warning all read this table.
#pragma once

#include "config/config.hpp"

#include <nlohmann/json_fwd.hpp>

#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace rsd {

// live: Service::reload applies a change; restart: a reload warns that it waits
// for a restart (listeners, DDS participants and their options are made once).
enum class Reload { live, restart };

struct ConfigKey {
  const char* file;   // the key in the JSON file
  const char* flag;   // the long flag, without "--"
  char short_flag;    // '\0': none
  bool takes_value;   // false: a switch (--no-usb)
  Reload reload;
  // The file's value onto `config`; `at` is 'FILE: "key"', the messages' prefix.
  void (*from_file)(const nlohmann::json& value, Config& config, const std::string& at);
  // The flag's text onto `flags` (a Config holding only what flags set); `first`:
  // the flag's first time, after which a repeated flag (--domain) adds to it.
  void (*from_flag)(const std::string& text, Config& flags, bool first, const std::string& where);
  // This key's fields of `from` onto `to`: the flags over the file.
  void (*copy)(const Config& from, Config& to);
  bool (*same)(const Config& a, const Config& b);
};

// In --help's order. Defaults are Config's member initializers.
std::span<const ConfigKey> config_keys();

const ConfigKey* find_file_key(std::string_view key);
// "--domain" or "-d"; nullptr for any other argument.
const ConfigKey* find_flag(std::string_view arg);

// The keys whose values differ between the two configurations, in table order;
// restart_only_changes: only those a reload cannot apply (what it warns about).
std::vector<std::string> changed_keys(const Config& a, const Config& b);
std::vector<std::string> restart_only_changes(const Config& running, const Config& next);

}  // namespace rsd
