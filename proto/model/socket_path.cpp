#include "rsd_model/socket_path.hpp"

#include <unistd.h>

#include <cstdlib>

namespace rsd::model {

std::string default_socket_path(const char* runtime_directory, const char* xdg_runtime_dir,
                                unsigned euid) {
  if (runtime_directory && *runtime_directory) {
    // systemd may list several directories separated by ':'; the first is ours.
    std::string dir = runtime_directory;
    return dir.substr(0, dir.find(':')) + "/api.sock";
  }
  if (euid == 0) return kSystemSocket;
  if (xdg_runtime_dir && *xdg_runtime_dir) return std::string(xdg_runtime_dir) + "/rs-discoveryd.sock";
  return "/tmp/rs-discoveryd-" + std::to_string(euid) + ".sock";
}

std::string default_socket_path() {
  return default_socket_path(std::getenv("RUNTIME_DIRECTORY"), std::getenv("XDG_RUNTIME_DIR"),
                             static_cast<unsigned>(geteuid()));
}

}  // namespace rsd::model
