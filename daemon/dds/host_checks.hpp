// Hung or gone: the hosts of cameras a domain lost by their servers' lease, probed
// (net::HostProbe) on the main thread until each is judged present or unreachable,
// and the verdict handed to the table (the removal's history record and gone entry).
#pragma once

#include "dds/domain_book.hpp"
#include "net/host_probe.hpp"
#include "table/shared_table.hpp"

#include <chrono>
#include <optional>
#include <vector>

namespace rsd::dds {

class HostChecks {
 public:
  using Clock = std::chrono::steady_clock;

  HostChecks(SharedTable& table, int domain) : table_(table), domain_(domain) {}

  // Probes begin; a server with several devices lost at once is probed once.
  void add(std::vector<LeaseLoss> losses, Clock::time_point now);
  // Reads the probes; how soon to look again (nothing: no probe running).
  std::optional<Clock::duration> poll(Clock::time_point now);
  std::size_t running() const { return checks_.size(); }

 private:
  struct Check {
    std::vector<LeaseLoss> losses;  // the devices of one server
    net::HostProbe probe;
    Clock::time_point since;
  };
  // Probes at once: each holds a socket per address. Beyond it, a loss is not probed.
  static constexpr std::size_t kMaxChecks = 64;
  SharedTable& table_;
  int domain_;
  std::vector<Check> checks_;
};

}  // namespace rsd::dds
