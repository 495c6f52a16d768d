"""Selecting another host's USB cameras in every client (issue 25: "a --host filter",
"source/sources extended in ... every client"): the Python package's host= filter
and typed Device.host, `python -m rsdiscovery --host`, and `rs-discover list/watch
--host` through the C++ library's DeviceFilter::host, against the real daemon.

One daemon on a host of its own (sharebed) with a camera on its own USB, and a
sharer on its domain (tools/share_peer.py) announcing the cameras of two hosts,
rig-a and rig-b, as their daemons would.
"""
import json
import os
import subprocess
import sys

import pytest

from conftest import TESTS_DIR, JsonLinesProcess, wait_for
from sharebed import D435, site  # noqa: F401 (site: the fixture)
from usbbed import in_umockdev

sys.path.insert(0, os.path.join(TESTS_DIR, "client"))
PACKAGE_SRC = os.path.join(os.path.dirname(TESTS_DIR), "client", "python", "src")
sys.path.insert(0, PACKAGE_SRC)
from client_util import CLI, WatchProcess, rs_discover  # noqa: E402
from test_completion import bash_complete  # noqa: E402

import rsdiscovery  # noqa: E402

pytestmark = pytest.mark.skipif(not in_umockdev(), reason="run under umockdev-wrapper (ctest does)")

ADDRESSES = {"rig-a": ["192.0.2.10", "198.51.100.10"], "rig-b": ["192.0.2.11"]}


def event_streams(d):
    """The daemon's open event streams (rsd_event_streams in /metrics)."""
    status, _, body = d.request("/metrics")
    assert status == 200
    (line,) = [x for x in body.decode().splitlines() if x.startswith("rsd_event_streams ")]
    return int(float(line.split()[1]))


class Sharer(JsonLinesProcess):
    """Another daemon's shares, written one camera at a time on the daemon's domain."""

    def __init__(self, site):
        super().__init__(site.lan.prefix(0) + [sys.executable, os.path.join(TESTS_DIR, "tools", "share_peer.py"),
                                               "--domain", str(site.domain)], stdin=subprocess.PIPE)
        assert self.lines.get(timeout=40) == {"matched": True}

    def share(self, host, serial):
        data = json.dumps({"host": {"name": host, "addresses": ADDRESSES[host]},
                           "device": {"name": "Intel RealSense D455", "serial": serial, "product-id": "0B5C"}})
        self.proc.stdin.write(json.dumps({"host": host, "camera": f"usb-{serial}", "version": 1, "data": data}) + "\n")
        self.proc.stdin.flush()
        assert self.lines.get(timeout=30) == {"ok": True}
        return f"usb-{serial}.{host}"

    def close(self):
        self.proc.stdin.close()
        self.proc.wait(20)


def test_every_client_selects_another_hosts_cameras_by_its_name(site):
    s = site(1)
    s.beds[0].plug("d435-usb2")  # this host's own camera: never another host's
    d = s.start(0, share=False)
    ep = "unix:" + d.socket
    sharer = Sharer(s)
    try:
        a1, b1 = sharer.share("rig-a", "100000000001"), sharer.share("rig-b", "200000000001")
        local = "usb-" + D435
        wait_for(lambda: {x["id"] for x in d.devices()} == {a1, b1, local}, timeout=20, what="both hosts' cameras")

        # Python: host= is the daemon's ?host= (any case); Device.host typed, None when not shared.
        client = rsdiscovery.Client(ep)
        (dev,) = client.list_devices(host="RIG-A")
        assert dev.id == a1 and dev.source == "remote-usb"
        assert isinstance(dev.host, rsdiscovery.Host)
        assert (dev.host.name, dev.host.addresses) == ("rig-a", tuple(ADDRESSES["rig-a"]))
        assert dev.host.participant_guid == dev.raw["host"].get("participant-guid")
        assert dev.host.raw == dev.raw["host"]
        assert {x.id: x.host for x in client.list_devices(source="usb")} == {local: None}
        assert client.list_devices(host="rig-c") == []
        assert [x.id for x in rsdiscovery.list_devices(host="rig-b", endpoint=ep)] == [b1]
        assert client.wait_for(host="rig-b", timeout=5).id == b1
        with pytest.raises(ValueError, match="remote-usb"):
            client.list_devices(host="rig-a", source="usb")
        with pytest.raises(ValueError):
            client.list_devices(host="")
        r = subprocess.run([sys.executable, "-m", "rsdiscovery", "--endpoint", ep, "--json", "list", "--host", "rig-a"],
                           capture_output=True, text=True, timeout=30, env=dict(os.environ, PYTHONPATH=PACKAGE_SRC))
        assert r.returncode == 0, r.stderr
        assert [x["id"] for x in json.loads(r.stdout)] == [a1]

        # rs-discover: list and --format through the library's DeviceFilter::host.
        r = rs_discover("list", "--host", "Rig-A", "-q", endpoint=ep)
        assert r.returncode == 0 and r.stdout.split() == [a1], r.stdout + r.stderr
        r = rs_discover("list", "--format", "{id} {host.name} {host.addresses}", endpoint=ep)
        assert r.returncode == 0, r.stderr
        assert sorted(line.rstrip() for line in r.stdout.splitlines()) == sorted(
            [f"{a1} rig-a {','.join(ADDRESSES['rig-a'])}", f"{b1} rig-b {','.join(ADDRESSES['rig-b'])}", local])
        env = dict(os.environ, PATH=os.path.dirname(CLI) + os.pathsep + os.environ["PATH"], RS_DISCOVERY_ENDPOINT=ep)
        assert bash_complete("rs-discover watch --host ", env) == ["rig-a", "rig-b"]
        assert "--host" in bash_complete("rs-discover watch --h", env)
        r = rs_discover("watch", "--host", "rig-a", "--source", "dds", endpoint=ep)
        assert r.returncode == 2 and "remote-usb" in r.stderr, r.stderr
        r = rs_discover("watch", "--host", "rig-b", "--initial", "--json", "--count", "1", endpoint=ep)
        assert r.returncode == 0, r.stderr
        assert [json.loads(x)["device"]["id"] for x in r.stdout.splitlines()] == [b1]

        # Watches follow only their host: rig-a's watch in Python, rig-b's in rs-discover.
        py = client.watcher(host="rig-a")
        cli = WatchProcess(ep, "--host", "rig-b")
        cli_json = WatchProcess(ep, "--host", "rig-b", "--json")
        try:
            # The watches report what happens after they connect: share nothing before
            # all three streams are open (a loaded machine starts a process slowly).
            wait_for(lambda: event_streams(d) == 3, timeout=20, what="the three watches connected")
            a2 = sharer.share("rig-a", "100000000002")  # before rig-b's: the watch of rig-b would see it first
            b2 = sharer.share("rig-b", "200000000002")
            a3 = sharer.share("rig-a", "100000000003")
            seen = []
            while a3 not in seen:
                e = py.next(timeout=20)
                assert e is not None, seen
                seen.append(e.device.id)
                assert e.type == "added" and e.device.host is not None
            assert seen == [a2, a3]
            wait_for(lambda: any(b2 in line for line in cli.lines) and cli_json.lines, timeout=20,
                     what="rs-discover watch --host rig-b reports rig-b's camera")
        finally:
            py.close()
            cli.interrupt()
            cli_json.interrupt()
        assert len(cli.lines) == 1 and "added" in cli.lines[0], cli.lines
        assert f"on rig-b ({ADDRESSES['rig-b'][0]})" in cli.lines[0], cli.lines
        assert [json.loads(x)["device"]["id"] for x in cli_json.lines] == [b2], cli_json.lines
    finally:
        sharer.close()
