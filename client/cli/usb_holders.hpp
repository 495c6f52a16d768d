// Who holds a USB camera open: the processes with one of its device nodes among their
// open files, found as fuser(1) finds them, by reading /proc/*/fd. The daemon cannot
// do this (its unit hides other processes: ProtectProc=invisible), so rs-discover
// does it on the user's behalf, with the user's own rights.
#pragma once

#include <sys/types.h>

#include <string>
#include <vector>

namespace rsdiscover {

struct UsbHolder {
  pid_t pid = 0;
  uid_t uid = 0;
  std::string user;     // the name of uid, or the number when the system has none
  std::string command;  // its command line, arguments joined by spaces ("[comm]" when it has none)
  std::vector<std::string> nodes;  // which of the camera's nodes it holds, in their given order
};

struct UsbHolders {
  std::vector<UsbHolder> holders;  // by pid
  // Processes whose open files this user may not read (another user's, without root):
  // a holder may be among them.
  std::size_t unreadable = 0;
};

// The processes under `proc_root` (normally "/proc") holding any of `nodes` open. A file
// descriptor matches a node when it is the same file (device and inode, as the node
// path resolves here: also under umockdev's redirection) or the same character device
// (st_rdev: another device file of it, as in a container's own /dev). Nodes that do not
// exist here are skipped. The scanning process itself is left out.
UsbHolders find_usb_holders(const std::vector<std::string>& nodes, const std::string& proc_root = "/proc");

}  // namespace rsdiscover
