// HostChecks (host_checks.hpp).
#include "dds/host_checks.hpp"

#include "log/log.hpp"

#include <algorithm>

namespace rsd::dds {

void HostChecks::add(std::vector<LeaseLoss> losses, Clock::time_point now) {
  for (auto& loss : losses) {
    const auto same = std::find_if(checks_.begin(), checks_.end(),
                                   [&](const Check& c) { return c.losses.front().addresses == loss.addresses; });
    if (same != checks_.end()) {
      same->losses.push_back(std::move(loss));
      continue;
    }
    if (checks_.size() >= kMaxChecks) {
      log::debug([&] { return log::domain_prefix(domain_) + "too many hosts probed at once; not probing " + loss.entry_id; });
      continue;
    }
    net::HostProbe probe(loss.addresses, now);
    checks_.push_back({{std::move(loss)}, std::move(probe), now});
  }
}

std::optional<HostChecks::Clock::duration> HostChecks::poll(Clock::time_point now) {
  for (auto it = checks_.begin(); it != checks_.end();) {
    const auto verdict = it->probe.poll(now);
    const LeaseLoss& first = it->losses.front();
    const std::string host = "server '" + first.server + "' at " + first.addresses.front();
    const auto took = std::chrono::duration_cast<std::chrono::milliseconds>(now - it->since).count();
    if (verdict) {
      for (const auto& loss : it->losses) table_.judge_host(loss.entry_id, loss.generation, *verdict);
      log::notice(log::domain_prefix(domain_) + "device " + first.entry_id + " lost by lease: " +
                  std::string(model::to_string(*verdict)) + ", " + host +
                  (*verdict == model::HostVerdict::present
                       ? " still answers while DDS is silent: its server hung (power-cycle a PoE camera)"
                       : " does not answer: check its cable, switch or power") +
                  " (judged in " + std::to_string(took) + " ms)");
    } else if (it->probe.given_up(now)) {
      log::info(log::domain_prefix(domain_) + "device " + first.entry_id + " lost by lease: no verdict on " + host +
                " after " + std::to_string(took) + " ms (no answer either way)");
    } else {
      ++it;
      continue;
    }
    it = checks_.erase(it);
  }
  if (checks_.empty()) return std::nullopt;
  // An ICMP answer comes within milliseconds of a datagram; this is how late it is read.
  return std::chrono::milliseconds(100);
}

}  // namespace rsd::dds
