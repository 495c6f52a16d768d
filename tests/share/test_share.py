"""USB cameras shared between daemons (issue 25, section 1): daemons on hosts of
their own (network namespaces on one switch, netns.Lan), each with its own
emulated USB bus (umockdev, usbbed.UsbBed) and host name, as a rig of PCs is.

What a user checks: another host's camera in `GET /v1/devices` (source
remote-usb, the host's name and address), gone when it is unplugged there, when
that daemon stops or dies (lease), never shared without share-usb, never echoed
back to its own host, and a hostile sharer capped and counted in /v1/domains.
"""
import json
import os
import signal
import subprocess
import sys
import time

import pytest

from conftest import TESTS_DIR, JsonLinesProcess, wait_for
from sharebed import D435, D455, note_time, site  # noqa: F401 (site: the fixture)
from usbbed import in_umockdev

sys.path.insert(0, os.path.join(TESTS_DIR, "api"))
sys.path.insert(0, os.path.join(TESTS_DIR, "client"))
sys.path.insert(0, os.path.join(os.path.dirname(TESTS_DIR), "client", "python", "src"))
from api_util import validate_response  # noqa: E402
from client_util import CLI, rs_discover  # noqa: E402

import rsdiscovery  # noqa: E402

pytestmark = pytest.mark.skipif(not in_umockdev(), reason="run under umockdev-wrapper (ctest does)")


def listed(daemon):
    return {d["id"]: d for d in daemon.devices()}


def has(daemon, dev_id):
    return dev_id in listed(daemon)


def lacks(daemon, dev_id):
    return dev_id not in listed(daemon)


def test_a_plugged_camera_is_listed_on_other_hosts_until_unplugged(site):
    s = site(3)
    a, b = s.start(0), s.start(1, share=False)
    s.beds[1].plug("d435-usb2")  # host1 does not share: nobody else may list it
    c = s.start(2)
    wait_for(lambda: has(b, "usb-" + D435), what="host1 lists its own camera")

    t0 = time.monotonic()
    path = s.beds[0].plug("d455-usb3")
    wanted = f"usb-{D455}.host0"
    wait_for(lambda: has(b, wanted), timeout=10, what="host1 lists host0's camera")
    note_time("plug-to-listed-other-host", time.monotonic() - t0)
    wait_for(lambda: has(c, wanted), timeout=10, what="host2 lists host0's camera")

    cam = listed(b)[wanted]
    assert cam["source"] == "remote-usb" and cam["sources"] == ["remote-usb"]
    assert cam["host"]["name"] == "host0"
    assert cam["host"]["addresses"] == [s.lan.ips[0]]
    assert cam["serial"] == D455 and cam["name"] == "Intel RealSense D455"
    assert cam["usb"]["port-path"] and "sysfs-path" not in cam["usb"]
    assert cam["domain"] == s.domain
    # The document is the spec's, and the source filter selects it.
    validate_response("/v1/devices", 200, b.get_json("/v1/devices"))
    assert [d["id"] for d in b.devices("?source=remote-usb")] == [wanted]
    assert [d["id"] for d in b.devices("?source=usb")] == ["usb-" + D435]
    assert [d["id"] for d in b.devices("?host=HOST0")] == [wanted]  # the host's name, any case
    assert [d["id"] for d in b.devices(f"?address={s.lan.ips[0]}")] == [wanted]
    assert b.devices("?host=host2") == []
    # The clients pass the source through: the Python package and rs-discover.
    got = rsdiscovery.Client("unix:" + b.socket).list_devices(source="remote-usb")
    assert [(d.id, d.source) for d in got] == [(wanted, "remote-usb")]
    if os.path.exists(CLI):  # built unless -DRSD_BUILD_CLIENT=OFF
        r = rs_discover("list", "--source", "remote-usb", "--json", endpoint="unix:" + b.socket)
        assert r.returncode == 0, r.stderr
        assert [(d["id"], d["host"]["name"]) for d in json.loads(r.stdout)["devices"]] == [(wanted, "host0")]
        # --host picks another host's cameras by its name, and the table says whose they are.
        r = rs_discover("list", "--host", "HOST0", "-q", endpoint="unix:" + b.socket)
        assert r.returncode == 0 and r.stdout.split() == [wanted], r.stdout + r.stderr
        assert rs_discover("list", "--host", "host2", "-q", endpoint="unix:" + b.socket).stdout == ""
        r = rs_discover("list", "--no-headers", endpoint="unix:" + b.socket)
        row = [line for line in r.stdout.splitlines() if D455 in line]
        assert len(row) == 1 and "on host0" in row[0] and s.lan.ips[0] in row[0], r.stdout
        r = rs_discover("list", "--host", "host0", "--source", "dds", endpoint="unix:" + b.socket)
        assert r.returncode == 2 and "remote-usb" in r.stderr
    # host0 lists its camera once, as today's local USB camera: its own share is not echoed.
    own = listed(a)
    assert list(own) == [f"usb-{D455}"]
    assert own[f"usb-{D455}"]["source"] == "usb" and own[f"usb-{D455}"]["sources"] == ["usb"]
    # host1 shares nothing: host2 saw host1's daemon on the network, and no camera of it.
    wait_for(lambda: any(p.get("host") == "host1" for p in c.get_json("/v1/participants")["participants"]),
             what="host2 sees host1's daemon")
    assert [d for d in c.devices() if d.get("host", {}).get("name") == "host1"] == []
    assert sorted(listed(c)) == [wanted]
    if os.path.exists(CLI):
        # doctor names who shares with host1's daemon, and the daemon it hears sharing none.
        wait_for(lambda: any(p.get("host") == "host2" for p in b.get_json("/v1/participants")["participants"]),
                 what="host1 sees host2's daemon")
        r = rs_discover("doctor", "--json", "--listen", "0", endpoint="unix:" + b.socket)
        sharing = [f for f in json.loads(r.stdout)["findings"] if f["topic"] == "sharing"]
        assert {(f["verdict"], f["text"]) for f in sharing} == {
            ("ok", f"host 'host0' at {s.lan.ips[0]} shares 1 USB camera (domain {s.domain})"),
            ("info", "rs-discoveryd on 'host2' shares no USB camera with this one (it runs without share-usb, "
                     "or has none plugged)")}, r.stdout

    t0 = time.monotonic()
    s.beds[0].unplug(path)
    wait_for(lambda: lacks(b, wanted) and lacks(c, wanted), timeout=10, what="host0's camera gone everywhere")
    note_time("unplug-to-removed-other-hosts", time.monotonic() - t0)
    assert listed(a) == {}


def test_stop_kill_and_a_daemon_started_last(site):
    s = site(3)
    # The same serial on two hosts: two cameras, two entries.
    s.beds[0].plug("d455-usb3")
    s.beds[1].plug("d455-usb3")
    s.beds[1].plug("d435-usb2")
    a, b = s.start(0), s.start(1)
    on_a, on_b = f"usb-{D455}.host0", f"usb-{D455}.host1"
    wait_for(lambda: has(a, on_b) and has(b, on_a), timeout=10, what="host0 and host1 list each other's cameras")
    assert sorted(listed(a)) == sorted([f"usb-{D455}", on_b, f"usb-{D435}.host1"])
    assert listed(a)[f"usb-{D455}"]["sources"] == ["usb"]  # the local one stays as it was

    # A daemon started last lists every shared camera as soon as it is ready.
    c = s.start(2, wait=False)
    c.wait_ready()
    ready = time.monotonic()
    every = sorted([on_a, on_b, f"usb-{D435}.host1"])
    wait_for(lambda: sorted(listed(c)) == every, timeout=10, what="the late daemon lists all shared cameras")
    note_time("ready-to-all-listed-late-daemon", time.monotonic() - ready)
    assert time.monotonic() - ready < 2.0

    # A daemon that stops takes its cameras off every other host at once.
    t0 = time.monotonic()
    assert a.stop() == 0
    wait_for(lambda: lacks(b, on_a) and lacks(c, on_a), timeout=10, what="host0's camera gone after its stop")
    note_time("stop-to-removed", time.monotonic() - t0)
    assert time.monotonic() - t0 < 3.0
    assert has(c, on_b)

    # One that dies is noticed when its lease expires (Cyclone's default: 10 s).
    t0 = time.monotonic()
    b.signal(signal.SIGKILL)
    b.proc.wait()
    wait_for(lambda: listed(c) == {}, timeout=25, what="host1's cameras gone after its lease")
    note_time("sigkill-to-removed", time.monotonic() - t0)


def test_a_malformed_or_flooding_sharer_is_capped_and_counted(site):
    s = site(1)
    d = s.start(0, share=False)
    peer = JsonLinesProcess(s.lan.prefix(0) + [sys.executable, os.path.join(TESTS_DIR, "tools", "share_peer.py"),
                                               "--domain", str(s.domain)], stdin=subprocess.PIPE)
    try:
        line = peer.lines.get(timeout=40)
        assert line == {"matched": True}, line

        def send(**msg):
            peer.proc.stdin.write(json.dumps(msg) + "\n")
            peer.proc.stdin.flush()
            assert peer.lines.get(timeout=30) == {"ok": True}

        good = json.dumps({"host": {"name": "evil", "addresses": ["192.0.2.9"]}, "device": {"name": "x"}})
        send(host="evil", camera="usb-1", version=2, data=good)                  # a version not known
        send(host="evil", camera="dds-1-realsense.x", version=1, data=good)      # not a USB camera's id
        send(host="evil", camera="usb-2", version=1, data="{not json")
        send(host="other", camera="usb-3", version=1, data=good)                 # the document's host is not the key's
        send(flood=100, host="evil")                                             # beyond 64 per participant

        def rejected():
            return d.get_json("/v1/domains")["domains"][0]["rejected"]
        want = {"shared-version": 1, "shared-bad-key": 1, "shared-not-json": 1, "shared-bad-host": 1,
                "shared-participant-limit": 36}
        wait_for(lambda: all(rejected().get(k) == v for k, v in want.items()), timeout=20,
                 what="every refusal counted")
        validate_response("/v1/domains", 200, d.get_json("/v1/domains"))
        remote = [x for x in d.devices() if x["source"] == "remote-usb"]
        assert len(remote) == 64 and all(x["host"]["name"] == "evil" for x in remote)
        assert d.healthy()
    finally:
        peer.proc.stdin.close()
        peer.proc.wait(20)
    # The peer gone, so are its cameras.
    wait_for(lambda: d.devices() == [], timeout=20, what="the peer's cameras gone with it")
