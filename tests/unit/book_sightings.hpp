// What DomainBook's unit tests feed it: made-up writers of made-up servers (GUIDs
// as Cyclone prints them) and D455 device-infos of domain 7. Shared by the book's
// test files so the two describe one world.
#pragma once

#include "dds/domain_book.hpp"

#include <cstdio>
#include <string>

namespace book_test {

// Writer n of server `server` (a participant of its own, at 10.0.0.<server>).
inline rsd::dds::WriterIdentity writer(int server, int n) {
  char guid[40];
  std::snprintf(guid, sizeof guid, "010f%04x.aaaabbbb.00000000.%08x", server, 0x100 + n);
  return {guid, std::string(guid).substr(0, 27) + "000001c1", "server-" + std::to_string(server),
          {"10.0.0." + std::to_string(server % 256)}};
}

inline rsd::dds::Parsed info(const std::string& serial) {
  return rsd::dds::DeviceInfo{{{"name", "Intel RealSense D455"}, {"serial", serial},
                               {"topic-root", "realsense/D455_" + serial}},
                              "realsense/D455_" + serial};
}

inline std::string id(const std::string& serial) { return "dds-7-realsense.D455_" + serial; }

}  // namespace book_test
