#include "service/network_watch.hpp"

#include "log/log.hpp"

namespace rsd::service {

NetworkWatch::NetworkWatch(DomainSet& domains, net::InterfaceRules rules, bool follow)
    : domains_(domains),
      rules_(std::move(rules)),
      follow_(follow),
      follower_(follow ? net::select_interfaces(net::list_interfaces(), rules_) : std::vector<net::NetInterface>{}) {
  if (!follow_) {
    log::info("network interfaces: as the Cyclone DDS configuration names them (not followed)");
    return;
  }
  try {
    watch_ = std::make_unique<net::NetlinkWatch>();
  } catch (const std::exception& e) {  // DDS still works on what is there now
    log::warning(std::string(e.what()) + "; the domains stay on the interfaces they start with");
  }
  const auto& chosen = follower_.joined();
  log::info("network interfaces: " + net::describe(chosen));
  domains_.follow_network(chosen);  // made before any domain is joined: they start on these
}

void NetworkWatch::readable(Clock::time_point now) {
  if (!watch_ || !watch_->drain()) return;
  follower_.changed(net::select_interfaces(net::list_interfaces(), rules_), now);
}

NetworkWatch::Clock::duration NetworkWatch::tick(Clock::time_point now) {
  if (!follow_) return std::chrono::hours(1);
  if (auto chosen = follower_.due(now)) {
    log::notice("network changed: joining the DDS domains anew on " + net::describe(*chosen) +
                " (devices of servers still reachable stay listed)");
    domains_.follow_network(*chosen);
  }
  return follower_.wait(now).value_or(std::chrono::hours(1));
}

void NetworkWatch::apply(net::InterfaceRules rules, Clock::time_point now) {
  if (!follow_) return;
  rules_ = std::move(rules);
  follower_.changed(net::select_interfaces(net::list_interfaces(), rules_), now);
}

}  // namespace rsd::service
