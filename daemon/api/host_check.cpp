#include "api/host_check.hpp"

#include <algorithm>
#include <cctype>

#include <arpa/inet.h>
#include <unistd.h>

namespace rsd::api {

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return std::tolower(c); });
  return out;
}

// "name", "name:port", "1.2.3.4:port", "[::1]:port" -> the host alone; nothing if malformed.
bool host_part(std::string_view value, std::string& out) {
  if (!value.empty() && value.front() == '[') {
    const auto close = value.find(']');
    if (close == std::string_view::npos) return false;
    const auto rest = value.substr(close + 1);
    if (!rest.empty() && rest.front() != ':') return false;
    out = lower(value.substr(1, close - 1));
    return true;
  }
  const auto colon = value.find(':');
  if (colon != std::string_view::npos && value.find(':', colon + 1) != std::string_view::npos) {
    out = lower(value);  // a bare IPv6 address (not valid in Host, but unambiguous)
    return true;
  }
  out = lower(value.substr(0, colon));
  return !out.empty();
}

bool is_address(const std::string& host) {
  unsigned char buf[16];
  return inet_pton(AF_INET, host.c_str(), buf) == 1 || inet_pton(AF_INET6, host.c_str(), buf) == 1;
}

}  // namespace

HostCheck::HostCheck(const std::vector<std::string>& ours, bool wildcard, const std::vector<std::string>& extra)
    : any_(false), any_address_(wildcard) {
  names_.insert("localhost");
  std::string h;
  for (const auto& name : ours)
    if (host_part(name, h)) names_.insert(h);
  // On every address, the machine's own name is one of ours too.
  char name[256] = {};
  if (wildcard && gethostname(name, sizeof name - 1) == 0 && name[0]) names_.insert(lower(name));
  for (const auto& e : extra) {
    if (e == "*") any_ = true;
    else if (host_part(e, h)) names_.insert(h);
  }
}

bool HostCheck::allows(std::string_view host) const {
  if (any_) return true;
  while (!host.empty() && (host.back() == ' ' || host.back() == '\t')) host.remove_suffix(1);
  while (!host.empty() && (host.front() == ' ' || host.front() == '\t')) host.remove_prefix(1);
  if (host.empty()) return true;
  std::string h;
  if (!host_part(host, h)) return false;
  if (!h.empty() && h.back() == '.') h.pop_back();  // "localhost." is localhost
  if (names_.contains(h)) return true;
  // On a wildcard listener every address of the machine is ours; an address is
  // never what a rebinding page sends (it needs a name it controls).
  return any_address_ && is_address(h);
}

}  // namespace rsd::api
