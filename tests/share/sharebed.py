"""Hosts of their own for the sharing tests (issue 25): network namespaces on one
switch (netns.Lan), each with its own emulated USB bus (usbbed.UsbBed), host name
and rs-discoveryd; measured latencies noted for the report.
"""
import json
import os
import signal
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [os.path.join(HERE, "..", "usb"), os.path.join(HERE, "..", "interop")]

from conftest import Daemon, DomainLocks  # noqa: E402
from netns import Lan  # noqa: E402
from usbbed import UsbBed  # noqa: E402
from gi.repository import GLib  # noqa: E402 (usbbed made GI ready)


class HostBed(UsbBed):
    """One host's USB bus among several in this process. umockdev's preload finds
    its testbed through UMOCKDEV_DIR, which the newest Testbed set for the whole
    process: it is pointed at this bed's for each plug and unplug (its uevent would
    otherwise name a device of another bed, and fail)."""

    def _here(self):
        GLib.setenv("UMOCKDEV_DIR", self.root, True)

    def plug(self, name, devnum=None, serial=None):
        self._here()
        return super().plug(name, devnum, serial)

    def unplug(self, sys_path):
        self._here()
        super().unplug(sys_path)

D455 = "123622270732"
D435 = "819612070440"
TIMES_FILE = os.path.join(os.environ.get("RSD_BUILD_DIR", "/tmp"), "share-times.json")


def note_time(name, seconds):
    """Measured latencies, for the report (not asserted beyond the test's bounds)."""
    try:
        with open(TIMES_FILE) as f:
            times = json.load(f)
    except (OSError, ValueError):
        times = {}
    times.setdefault(name, []).append(round(seconds, 3))
    os.makedirs(os.path.dirname(TIMES_FILE), exist_ok=True)
    with open(TIMES_FILE, "w") as f:
        json.dump(times, f, indent=1)


class Site:
    """`n` hosts named host0..host{n-1}, each with a USB bus, one DDS domain;
    daemons started on demand, stopped (and the network removed) at the end."""

    def __init__(self, n, tmp_path, domain):
        self.lan = Lan(n)
        self.beds = [HostBed() for _ in range(n)]
        for bed in self.beds:
            bed.plug("root-hubs")  # an xHCI controller's root hubs, where cameras plug in
        self.tmp = str(tmp_path)
        self.domain = domain
        self.daemons = {}
        self.empty = os.path.join(self.tmp, "empty-config.json")
        with open(self.empty, "w") as f:
            f.write("{}")

    def start(self, i, share=True, wait=True):
        sock = os.path.join(self.tmp, f"host{i}-{len(self.daemons)}.sock")
        args = ["--domain", str(self.domain), "--config", self.empty, "--socket", sock, "--http", "off",
                "--log-level", "debug"] + (["--share-usb"] if share else [])
        d = Daemon(args, self.tmp, sock, None, self.beds[i].env(), self.lan.prefix(i, f"host{i}"))
        self.daemons[i] = d
        if wait:
            d.wait_ready()
        return d

    def close(self):
        codes = {}
        try:
            for i, d in self.daemons.items():
                codes[i] = (d.stop(), d)
        finally:
            self.lan.destroy()
        for i, (code, d) in codes.items():
            assert code in (0, -signal.SIGKILL), f"host{i}'s daemon exited with {code}:\n{d.log()[-4000:]}"


@pytest.fixture
def site(tmp_path):
    locks = DomainLocks()
    sites = []

    def make(n):
        s = Site(n, tmp_path, locks.take())
        sites.append(s)
        return s

    yield make
    try:
        for s in sites:
            s.close()
    finally:
        locks.release()
