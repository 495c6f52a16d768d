// A user's and a group's name by id, for messages about who owns the daemon's socket
// (the number when the system has none). Header-only: the library's connect errors
// and rs-discover doctor both name the socket's owner and group.
#pragma once

#include <grp.h>
#include <pwd.h>

#include <string>

namespace rsdiscovery::detail {

inline std::string user_name(uid_t uid) {
  if (const passwd* p = getpwuid(uid)) return p->pw_name;
  return std::to_string(uid);
}

inline std::string group_name(gid_t gid) {
  if (const group* g = getgrgid(gid)) return g->gr_name;
  return std::to_string(gid);
}

}  // namespace rsdiscovery::detail
