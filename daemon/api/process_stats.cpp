#include "api/process_stats.hpp"

#include <dirent.h>
#include <sys/resource.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <string>

namespace rsd::api {

std::optional<ProcessStats> read_process_stats() {
  std::ifstream stat_file("/proc/self/stat");
  std::string line;
  if (!std::getline(stat_file, line)) return std::nullopt;
  // The command name (field 2) is in parentheses and may hold spaces: fields are
  // counted from after its closing one, where field 3 (the state) starts.
  const auto close = line.rfind(')');
  if (close == std::string::npos) return std::nullopt;
  std::istringstream fields(line.substr(close + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0, starttime = 0, vsize = 0;
  long long rss_pages = 0;
  for (int n = 3; fields >> field; ++n) {
    if (n == 14) utime = std::stoull(field);
    else if (n == 15) stime = std::stoull(field);
    else if (n == 22) starttime = std::stoull(field);
    else if (n == 23) vsize = std::stoull(field);
    else if (n == 24) {
      rss_pages = std::stoll(field);
      break;
    }
  }
  const double ticks = static_cast<double>(sysconf(_SC_CLK_TCK));
  ProcessStats p;
  p.cpu_seconds = static_cast<double>(utime + stime) / ticks;
  p.virtual_bytes = vsize;
  p.resident_bytes = static_cast<std::uint64_t>(rss_pages > 0 ? rss_pages : 0) *
                     static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
  // Boot time (btime, seconds since the epoch) plus the start in ticks after it.
  std::ifstream proc_stat("/proc/stat");
  while (std::getline(proc_stat, line))
    if (line.rfind("btime ", 0) == 0) {
      p.start_time_seconds = std::stod(line.substr(6)) + static_cast<double>(starttime) / ticks;
      break;
    }
  if (DIR* fds = opendir("/proc/self/fd")) {
    while (const dirent* e = readdir(fds))
      if (e->d_name[0] != '.') ++p.open_fds;
    closedir(fds);
    --p.open_fds;  // the one opendir holds
  }
  rlimit limit{};
  if (getrlimit(RLIMIT_NOFILE, &limit) == 0) p.max_fds = limit.rlim_cur;
  return p;
}

}  // namespace rsd::api
