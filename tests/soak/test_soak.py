"""Soak (issue 11): cameras come and go every second over DDS (real realdds servers)
and USB (umockdev), 20 SSE clients watch, one client polls in a loop. At the end:
no watcher lost or got twice an event (event ids are consecutive generations), each
watcher's replayed table equals the daemon's, the table holds exactly the cameras
that are there, and RSS at the end is within 10 % of RSS after the first minute.

RSD_SOAK_SECONDS sets the length: 120 in the suite (ctest soak), 1800 for the
documented long run (tests/soak/run, which also keeps the RSS curve).
"""
import json
import os
import sys
import threading
import time

import pytest

# The API suite's HTTP helpers and the USB suite's emulated bus.
_TESTS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [os.path.join(_TESTS, "api"), os.path.join(_TESTS, "usb")]

from conftest import SANITIZED, Daemon, DomainLocks, RealddsServer, device_info, free_port, rss_kb, wait_for
from api_util import SSEStream, request  # noqa: E402
from usbbed import UsbBed, in_umockdev  # noqa: E402

pytestmark = pytest.mark.skipif(not in_umockdev(), reason="run under umockdev-wrapper (ctest does)")

SECONDS = int(os.environ.get("RSD_SOAK_SECONDS", "120"))
WATCHERS = 20
CURVE_FILE = os.environ.get("RSD_SOAK_CURVE") or os.path.join(os.environ.get("RSD_BUILD_DIR", "/tmp"), "soak-rss.json")


class Watcher:
    """One SSE client: replays the stream onto its own copy of the table."""

    def __init__(self, target):
        status, _, body = request(target, "/v1/devices")
        assert status == 200
        listing = json.loads(body)
        self.table = {d["id"]: d for d in listing["devices"]}
        self.generation = listing["generation"]
        self.stream = SSEStream(target, f"/v1/events?since={self.generation}")
        assert self.stream.status == 200
        self.ids = []
        self.problems = []

    def drain(self, until=None, timeout=0.0):
        """Applies what has arrived; with `until`, waits for that generation."""
        deadline = time.monotonic() + timeout
        while True:
            if until is not None and self.generation >= until:
                return
            left = deadline - time.monotonic()
            if until is None and self.stream.queue.empty():
                return
            msg = self.stream.next(timeout=max(0.05, left))
            assert msg is not None, "an event stream ended"
            e = msg.get("event")
            if e == "resync":
                self.problems.append(f"resync at {msg.get('id')}")
                continue
            event_id = int(msg["id"])
            self.ids.append(event_id)
            if event_id != self.generation + 1:
                self.problems.append(f"after {self.generation} came {event_id}")
            self.generation = event_id
            device = json.loads(msg["data"])
            if e in ("added", "changed", "described"):
                if e == "described":
                    continue
                self.table[device["id"]] = device
            elif e == "removed":
                if self.table.pop(device["id"], None) is None:
                    self.problems.append(f"removed {device['id']}, which it did not have")


class Poller(threading.Thread):
    """A client listing in a loop with If-None-Match, as a dashboard does."""

    def __init__(self, target):
        super().__init__(daemon=True)
        self.target = target
        self.stop = threading.Event()
        self.counts = {200: 0, 304: 0}
        self.errors = []

    def run(self):
        etag = None
        while not self.stop.is_set():
            try:
                status, headers, _ = request(self.target, "/v1/devices",
                                             headers={"If-None-Match": etag} if etag else None)
                self.counts[status] = self.counts.get(status, 0) + 1
                etag = headers.get("etag", etag)
            except Exception as e:  # noqa: BLE001
                self.errors.append(repr(e))
            self.stop.wait(0.05)


def test_soak(tmp_path):
    locks = DomainLocks()
    domain = locks.take()
    bed = UsbBed()
    bed.plug("root-hubs")
    sock = os.path.join(tmp_path, "api.sock")
    port = free_port()
    empty = os.path.join(tmp_path, "empty-config.json")  # not /etc/rs-discoveryd's
    with open(empty, "w") as f:
        f.write("{}")
    d = Daemon(["--config", empty, "--domain", str(domain), "--socket", sock, "--http", f"127.0.0.1:{port}"],
               str(tmp_path), sock, port, bed.env())
    servers = []
    watchers = []
    poller = None
    try:
        d.wait_ready()
        servers = [RealddsServer(domain, [], name=f"soak-{i}") for i in range(2)]
        watchers = [Watcher(sock if i % 2 else ("127.0.0.1", port)) for i in range(WATCHERS)]
        poller = Poller(sock)
        poller.start()

        live = {}  # server index -> topic-root of its live device
        usb_path = None
        serial = 0
        curve = []
        t0 = time.monotonic()
        tick = 0
        while time.monotonic() - t0 < SECONDS:
            tick += 1
            # DDS: each server toggles one camera; USB: one camera toggles.
            for i, s in enumerate(servers):
                if i in live:
                    s.command(cmd="disconnect", **{"topic-root": live[i]})
                    s.command(cmd="remove", **{"topic-root": live.pop(i)})
                else:
                    # Cameras come back: a pool of serials per server, as on a real
                    # network (every new serial is a new set of DDS topics, which
                    # DDS remembers; an endless supply of them is not what a soak is).
                    serial += 1
                    info = device_info(0, serial=f"9{i}{serial % 8:010d}")
                    s.command(cmd="add", info=info)
                    live[i] = info["topic-root"]
            if usb_path:
                bed.unplug(usb_path)
                usb_path = None
            else:
                usb_path = bed.plug("d455-usb3", devnum=10 + tick % 100, serial=f"8{tick % 8:011d}")
            for w in watchers:
                w.drain()
            elapsed = time.monotonic() - t0
            if not curve or elapsed - curve[-1][0] >= min(10, SECONDS / 10):
                curve.append((round(elapsed, 1), rss_kb(d.proc.pid)))
            # One change a second per source: sleep out the rest of the second.
            time.sleep(max(0.0, tick - (time.monotonic() - t0)))

        # Quiet: what is there now is what the table must say.
        expected = {f"dds-{domain}-{root.replace('/', '.')}" for root in live.values()}
        wait_for(lambda: {x["id"] for x in json.loads(request(sock, "/v1/devices")[2])["devices"]
                          if x["source"] == "dds" or "dds" in x.get("sources", [])} == expected,
                 15, what="the DDS cameras that are there, and only those")
        devices = json.loads(request(sock, "/v1/devices")[2])
        usb_ids = {x["id"] for x in devices["devices"] if x["source"] == "usb"}
        assert len(usb_ids) == (1 if usb_path else 0), usb_ids
        final = {x["id"]: x for x in devices["devices"]}
        for w in watchers:
            w.drain(until=devices["generation"], timeout=15)
            assert not w.problems, w.problems[:5]
            assert {k: v for k, v in w.table.items()} == final
        counts = [len(w.ids) for w in watchers]
        assert len(set(counts)) == 1, counts  # every watcher saw every event

        poller.stop.set()
        poller.join(10)
        assert not poller.errors, poller.errors[:3]
        assert poller.counts[200] > 0

        curve.append((round(time.monotonic() - t0, 1), rss_kb(d.proc.pid)))
        with open(CURVE_FILE, "w") as f:
            json.dump({"seconds": SECONDS, "events_per_watcher": counts[0], "polls": poller.counts,
                       "rss_kb": curve}, f, indent=1)
        print(f"soak {SECONDS} s: {counts[0]} events per watcher, polls {poller.counts}, RSS curve {curve}")
        if not SANITIZED:
            # The baseline is after the first minute (after half the run, for a short one):
            # by then every buffer and arena the daemon needs has been made.
            baseline = next(kb for at, kb in curve if at >= min(60, SECONDS / 2))
            assert curve[-1][1] <= baseline * 1.10, curve
    finally:
        if poller:
            poller.stop.set()
        for w in watchers:
            w.stream.close()
        for s in servers:
            s.kill()
        code = d.stop()
        locks.release()
    assert code == 0, d.log()[-3000:]
