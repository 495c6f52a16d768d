// rs-discoveryd's client library: the cameras the daemon expects and which it lists
// (Client::expected(), GET /v1/expected). Included by rsdiscovery.hpp.
#pragma once

#include <string>
#include <vector>

namespace rsdiscovery {

// The cameras the daemon's configuration expects (its `expect` key, --expect), and
// which of them it lists now (GET /v1/expected).
struct ExpectedCamera {
  std::string name;        // the user's name for it ("front"); "" when unnamed
  std::string serial;      // as configured: a serial, or
  std::string topic_root;  // a topic-root
  std::string id;          // present: the device that is it
  std::string last_seen;   // missing: when the daemon last listed it, "" unknown
  std::string reason;      // missing: why it left the list, "" unknown
  const std::string& key() const { return serial.empty() ? topic_root : serial; }
};

struct Expected {
  bool complete = false;  // the daemon's first discovery is over
  std::vector<ExpectedCamera> present;
  std::vector<ExpectedCamera> missing;
  std::string json;
};

}  // namespace rsdiscovery
