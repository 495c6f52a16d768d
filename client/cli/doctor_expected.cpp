// rs-discover doctor's first check: the cameras the daemon expects (its "expect" key)
// that it does not list, each with when it was last listed and why it went, before
// anything else the doctor finds.
#include "doctor.hpp"

namespace rsdiscover::doctor {

void check_expected(Report& r, const std::optional<rsdiscovery::Expected>& expected) {
  if (!expected) return;  // a daemon older than /v1/expected
  const auto total = expected->present.size() + expected->missing.size();
  if (total == 0) return;
  for (const auto& m : expected->missing) {
    std::string text = (m.name.empty() ? m.key() : m.name + " (" + m.key() + ")") + " is expected and not listed: " +
                       missing_since(m);
    if (!expected->complete) text += " (the daemon's first discovery still runs)";
    r.add(Verdict::fail, "expected", text);
  }
  if (expected->missing.empty())
    r.add(Verdict::ok, "expected", "all " + std::to_string(total) + " expected camera" + (total == 1 ? "" : "s") +
                                       " listed");
}

}  // namespace rsdiscover::doctor
