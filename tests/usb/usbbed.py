"""An emulated USB bus for the daemon (umockdev), built from the records in devices/.

The test process runs under `umockdev-wrapper` (see CMakeLists.txt), so umockdev's
preload library is in LD_PRELOAD and every child inherits it; the testbed's root
is handed to the daemon in UMOCKDEV_DIR (GLib sets it on the C side only, so
Python's os.environ does not carry it by itself).
"""
import os
import re

import gi

gi.require_version("UMockdev", "1.0")
from gi.repository import UMockdev  # noqa: E402

DEVICES_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "devices")


def in_umockdev():
    return "umockdev" in os.environ.get("LD_PRELOAD", "")


def load_record(name, devnum=None, serial=None):
    """The text of devices/<name>.umockdev, with devnum and/or serial rewritten
    (one device per record): a replug gets a new address, as on real hardware."""
    with open(os.path.join(DEVICES_DIR, name + ".umockdev")) as f:
        text = f.read()
    if devnum is not None:
        bus = int(re.search(r"^A: busnum=(\d+)$", text, re.M).group(1))
        text = re.sub(r"^N: bus/usb/(\d+)/\d+$", f"N: bus/usb/{bus:03d}/{devnum:03d}", text, flags=re.M)
        text = re.sub(r"^E: DEVNAME=.*$", f"E: DEVNAME=/dev/bus/usb/{bus:03d}/{devnum:03d}", text, flags=re.M)
        text = re.sub(r"^E: DEVNUM=.*$", f"E: DEVNUM={devnum:03d}", text, flags=re.M)
        text = re.sub(r"^A: devnum=.*$", f"A: devnum={devnum}", text, flags=re.M)
    if serial is not None:
        text = re.sub(r"^A: serial=.*$", f"A: serial={serial}", text, flags=re.M)
    return text


def sys_paths(text):
    return ["/sys" + m for m in re.findall(r"^P: (\S+)$", text, re.M)]


class UsbBed:
    def __init__(self):
        self.testbed = UMockdev.Testbed.new()
        self.root = self.testbed.get_root_dir()

    def env(self):
        """Environment for a daemon that must see this bus."""
        asan = os.environ.get("ASAN_OPTIONS", "")
        # umockdev's preload comes before libasan in a sanitized daemon: allowed.
        asan = (asan + ":" if asan else "") + "verify_asan_link_order=0"
        return {"UMOCKDEV_DIR": self.root, "ASAN_OPTIONS": asan}

    def plug(self, name, devnum=None, serial=None):
        """Adds the device(s) of a record (umockdev sends the "add" uevent);
        returns the sysfs path of its (last) device."""
        text = load_record(name, devnum, serial)
        assert self.testbed.add_from_string(text), name
        return sys_paths(text)[-1]

    def unplug(self, sys_path):
        """What the kernel does on unplug: the "remove" uevent, then the device goes."""
        self.testbed.uevent(sys_path, "remove")
        self.testbed.remove_device(sys_path)
