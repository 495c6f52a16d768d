// The daemon process's own figures for /metrics (process_cpu_seconds_total and
// the rest of the names Prometheus' client libraries use), read from /proc.
#pragma once

#include "api/format.hpp"

#include <optional>

namespace rsd::api {

// Nothing when /proc/self cannot be read (a sandbox without it).
std::optional<ProcessStats> read_process_stats();

}  // namespace rsd::api
