// find_usb_holders(): /proc/*/fd against a USB camera's device nodes (usb_holders.hpp).
#include "usb_holders.hpp"

#include "files.hpp"

#include "../src/account_names.hpp"

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <memory>
#include <optional>

namespace rsdiscover {
namespace {

struct NodeFile {
  std::string path;
  dev_t dev = 0;
  ino_t ino = 0;
  dev_t rdev = 0;  // 0 unless a character device
};

bool same_file(const NodeFile& node, const struct stat& st) {
  if (st.st_dev == node.dev && st.st_ino == node.ino) return true;
  return node.rdev != 0 && S_ISCHR(st.st_mode) && st.st_rdev == node.rdev;
}

std::optional<pid_t> pid_of(const char* name) {
  if (*name < '1' || *name > '9') return std::nullopt;
  char* end = nullptr;
  const long v = std::strtol(name, &end, 10);
  if (*end != '\0' || v <= 0) return std::nullopt;
  return static_cast<pid_t>(v);
}

// What ps shows: the arguments, or "[comm]" for a kernel thread or a process whose
// arguments are gone. Bounded, as a process may have megabytes of arguments.
std::string command_of(const std::string& dir) {
  constexpr std::size_t kMax = 1024;
  std::string args = read_file(dir + "/cmdline", kMax).value_or("");
  while (!args.empty() && args.back() == '\0') args.pop_back();
  // One line in a table: the separators become spaces, other control characters '?'
  // (as ps shows them).
  for (char& ch : args) {
    const auto u = static_cast<unsigned char>(ch);
    if (u == 0) ch = ' ';
    else if (u < 0x20 || u == 0x7f) ch = '?';
  }
  if (!args.empty()) return args;
  std::string comm = read_file(dir + "/comm").value_or("");
  comm = comm.substr(0, comm.find('\n'));
  return "[" + comm + "]";
}

using DirPtr = std::unique_ptr<DIR, int (*)(DIR*)>;

}  // namespace

UsbHolders find_usb_holders(const std::vector<std::string>& nodes, const std::string& proc_root) {
  std::vector<NodeFile> files;
  for (const auto& path : nodes) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) continue;  // not on this host (or gone): nothing holds it here
    files.push_back({path, st.st_dev, st.st_ino, S_ISCHR(st.st_mode) ? st.st_rdev : 0});
  }
  UsbHolders out;
  if (files.empty()) return out;
  DirPtr proc(::opendir(proc_root.c_str()), &::closedir);
  if (!proc) return out;
  const pid_t self = ::getpid();
  while (const dirent* e = ::readdir(proc.get())) {
    const auto pid = pid_of(e->d_name);
    if (!pid || *pid == self) continue;
    const std::string dir = proc_root + "/" + e->d_name;
    DirPtr fds(::opendir((dir + "/fd").c_str()), &::closedir);
    if (!fds) {
      if (errno == EACCES || errno == EPERM) ++out.unreadable;
      continue;  // ENOENT: it has exited meanwhile
    }
    std::vector<bool> held(files.size(), false);
    while (const dirent* fd = ::readdir(fds.get())) {
      if (fd->d_name[0] == '.') continue;
      struct stat st {};
      if (::stat((dir + "/fd/" + fd->d_name).c_str(), &st) != 0) continue;
      for (std::size_t i = 0; i < files.size(); ++i)
        if (same_file(files[i], st)) held[i] = true;
    }
    if (std::find(held.begin(), held.end(), true) == held.end()) continue;
    UsbHolder h;
    h.pid = *pid;
    struct stat owner {};
    if (::stat(dir.c_str(), &owner) == 0) h.uid = owner.st_uid;
    h.user = rsdiscovery::detail::user_name(h.uid);
    h.command = command_of(dir);
    for (std::size_t i = 0; i < files.size(); ++i)
      if (held[i]) h.nodes.push_back(files[i].path);
    out.holders.push_back(std::move(h));
  }
  std::sort(out.holders.begin(), out.holders.end(), [](const auto& a, const auto& b) { return a.pid < b.pid; });
  return out;
}

}  // namespace rsdiscover
