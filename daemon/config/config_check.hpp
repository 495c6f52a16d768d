// rs-discoveryd --check-config: a configuration error as an editor jumps to it.
#pragma once

#include <string>

namespace rsd {

// "PATH:LINE:COLUMN: what" for a ConfigError's message about a place in a config
// file: a JSON syntax error (where the parser stopped) or a bad value (the line of
// its top-level key). Any other message is returned as it is.
std::string locate_config_error(const std::string& message);

// The 1-based line and column of the top-level key `key` in the JSON object `text`,
// or {0, 0} when it is not there.
std::pair<int, int> top_level_key_position(const std::string& text, const std::string& key);

}  // namespace rsd
