// Whole files read and written with the system calls: rs-discover reads small files
// (a config, /proc) and writes one (~/.realsense-config.json). Through <fstream>
// the static libstdc++ brought its streams and locales into every cold start.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace rsdiscover {

// The first `max` bytes of the file at `path` (all of a /proc file, whose size says
// 0); nullopt when it cannot be opened or read.
std::optional<std::string> read_file(const std::string& path, std::size_t max = std::size_t{64} << 20);

// `text` into the file at `path`, created (0666 less the umask) or truncated; false,
// with errno, when it cannot be written whole.
bool write_file(const std::string& path, std::string_view text);

}  // namespace rsdiscover
