// Which Host headers the HTTP listener answers. A web page the user opens can
// make the browser fetch http://127.0.0.1:8035 under a DNS name the attacker
// controls (DNS rebinding); the browser then sends that name as Host. Refusing
// names we do not listen under (421) keeps the inventory out of such pages.
#pragma once

#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::api {

class HostCheck {
 public:
  HostCheck() = default;
  // `ours`: the names the listener is reached under (the configured HTTP host, the
  // address actually bound, e.g. a socket systemd passed); `wildcard`: bound to
  // 0.0.0.0 or ::, so any address of the machine is ours. `extra`: the configured
  // allowed-hosts; "*" among them turns the check off.
  HostCheck(const std::vector<std::string>& ours, bool wildcard, const std::vector<std::string>& extra);

  // `host`: the Host header's value, port included if given. No header at all
  // (HTTP/1.0) passes: browsers always send one.
  bool allows(std::string_view host) const;
  bool enabled() const { return !any_; }

 private:
  bool any_ = true;
  bool any_address_ = false;
  std::set<std::string> names_;  // lower case, no port, IPv6 without brackets
};

}  // namespace rsd::api
