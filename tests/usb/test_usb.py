"""Local USB cameras (issue 3), use case by use case, on an emulated USB bus.

The real rs-discoveryd runs as a child of this test, under umockdev (see usbbed.py):
libusb inside it enumerates the devices of tests/usb/devices/ and gets hotplug
events when a test plugs or unplugs one. Each test has its own testbed, DDS domain
(200-229), socket and port.
"""
import json
import os
import queue
import signal
import statistics
import threading
import time

import pytest

from conftest import Daemon, DomainLocks, UnixHTTPConnection, device_info, free_port, wait_for
from usbbed import UsbBed, in_umockdev

pytestmark = pytest.mark.skipif(not in_umockdev(), reason="run under umockdev-wrapper (ctest does)")

D455_SERIAL = "123622270732"
D455_ID = "usb-" + D455_SERIAL
D435_ID = "usb-819612070440"
LATENCY_FILE = os.path.join(os.environ.get("RSD_BUILD_DIR", "/tmp"), "usb-latency.json")


@pytest.fixture
def bed():
    return UsbBed()


@pytest.fixture
def usb_daemon(tmp_path, bed):
    """usb_daemon(extra=[...], env={...}) -> (Daemon, domain): USB on, one domain of 200..229."""
    locks = DomainLocks()
    started = []

    def start(extra=(), env=None, wait=True):
        domain = locks.take(200, 229)
        sock = os.path.join(tmp_path, f"api-{len(started)}.sock")
        port = free_port()
        args = ["--domain", str(domain), "--socket", sock, "--http", f"127.0.0.1:{port}", "--log-level", "debug"]
        full_env = bed.env()
        full_env.update(env or {})
        d = Daemon(args + list(extra), str(tmp_path), sock, port, full_env)
        started.append(d)
        if wait:
            d.wait_ready()
        return d, domain

    yield start
    try:
        for d in started:
            code = d.stop()
            # ASan/LSan/UBSan findings (a leak too) make the daemon exit non-zero.
            assert code == 0, f"daemon exited with {code}:\n{d.log()[-4000:]}"
    finally:
        locks.release()


class TimedEvents:
    """/v1/events read on a thread; each event stamped with its arrival time."""

    def __init__(self, daemon):
        self.queue = queue.Queue()
        self.conn = UnixHTTPConnection(daemon.socket, timeout=60)
        self.conn.request("GET", "/v1/events", headers={"Accept": "text/event-stream"})
        self.response = self.conn.getresponse()
        assert self.response.status == 200
        threading.Thread(target=self._read, daemon=True).start()
        self.next(types=("hello",))  # subscribed: everything from now on is seen

    def _read(self):
        event = {}
        try:
            for raw in self.response.fp:
                line = raw.decode("utf-8").rstrip("\r\n")
                if line == "":
                    if "event" in event:
                        event["t"] = time.monotonic()
                        event["json"] = json.loads(event.get("data", "null"))
                        self.queue.put(event)
                    event = {}
                elif not line.startswith(":"):
                    key, _, value = line.partition(":")
                    event[key] = value[1:] if value.startswith(" ") else value
        except (OSError, ValueError):
            pass
        self.queue.put(None)

    def next(self, timeout=5.0, types=("added", "changed", "removed")):
        deadline = time.monotonic() + timeout
        while True:
            try:
                ev = self.queue.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                pytest.fail(f"no {types} event within {timeout}s")
            assert ev is not None, "event stream ended"
            if ev["event"] in types:
                return ev

    def expect(self, kind, device_id, timeout=5.0):
        ev = self.next(timeout)
        assert (ev["event"], ev["json"]["id"]) == (kind, device_id), ev
        return ev

    def assert_quiet(self, timeout=0.3):
        """No device event for a while (the one way to show that nothing happened)."""
        try:
            ev = self.queue.get(timeout=timeout)
        except queue.Empty:
            return
        assert ev is None or ev["event"] not in ("added", "changed", "removed"), ev

    def close(self):
        self.conn.close()


def record_latency(name, samples_ms):
    data = {}
    if os.path.exists(LATENCY_FILE):
        with open(LATENCY_FILE) as f:
            data = json.load(f)
    data[name] = {"n": len(samples_ms), "median_ms": round(statistics.median(samples_ms), 2),
                  "p90_ms": round(sorted(samples_ms)[int(0.9 * (len(samples_ms) - 1))], 2),
                  "max_ms": round(max(samples_ms), 2)}
    with open(LATENCY_FILE, "w") as f:
        json.dump(data, f, indent=1)
    return data[name]


def usb_devices(daemon, query="?source=usb"):
    return {d["id"]: d for d in daemon.devices(query)}


def test_d455_on_usb3_present_at_start(bed, usb_daemon):
    bed.plug("root-hubs")
    bed.plug("d455-usb3")
    d, _ = usb_daemon()
    dev = wait_for(lambda: usb_devices(d).get(D455_ID), 5, what="the D455 listed")
    assert dev["source"] == "usb" and dev["sources"] == ["usb"]
    assert dev["name"] == "Intel RealSense D455"
    assert dev["serial"] == D455_SERIAL
    assert dev["product-id"] == "0B5C"
    assert dev["product-line"] == "D400"
    assert dev["recovery"] is False
    assert dev["usb"] == {"bus": 2, "address": 2, "port-path": "2-1", "speed": "super", "speed-mbps": 5000,
                          "vid": "8086", "pid": "0B5C", "usb-version": "3.20",
                          "sysfs-path": "/sys/devices/pci0000:00/0000:00:14.0/usb2/2-1",
                          "device-nodes": ["/dev/bus/usb/002/002"]}
    assert "warnings" not in dev
    assert dev["first-seen"] and dev["last-seen"]
    # The same over HTTP, by id, and through the source filter.
    assert d.get_json("/v1/devices/" + D455_ID, via="tcp")["serial"] == D455_SERIAL
    assert d.device_ids("?source=dds") == []
    assert d.device_ids("?product-line=D400") == [D455_ID]
    # The root hubs are not Intel devices: nothing else is listed.
    assert d.device_ids() == [D455_ID]
    # What the USB side itself reports, for users and monitoring.
    assert d.get_json("/healthz")["usb"] == {"state": "hotplug", "devices": 1}
    assert "rsd_usb_devices 1" in d.request("/metrics")[2].decode().splitlines()


def test_d435_hotplugged_on_usb2_is_warned_about_then_unplugged(bed, usb_daemon):
    bed.plug("root-hubs")
    d, _ = usb_daemon()
    events = TimedEvents(d)
    t0 = time.monotonic()
    path = bed.plug("d435-usb2")
    ev = events.expect("added", D435_ID)
    added_ms = (ev["t"] - t0) * 1000
    dev = ev["json"]
    assert dev["name"] == "Intel RealSense D435" and dev["product-id"] == "0B07"
    assert dev["usb"]["speed"] == "high" and dev["usb"]["speed-mbps"] == 480
    assert dev["usb"]["port-path"] == "1-3"
    [warning] = dev["warnings"]
    assert "USB 2" in warning and "USB 3" in warning and "480 Mbit/s" in warning
    assert d.get_json("/v1/devices/" + D435_ID)["warnings"] == [warning]
    # Logged as a warning too; the line may follow the event by a moment.
    wait_for(lambda: "warning: usb: " + D435_ID in d.log() and "USB 2 speed" in d.log(), 5, what="the warning logged")
    t0 = time.monotonic()
    bed.unplug(path)
    ev = events.expect("removed", D435_ID)
    removed_ms = (ev["t"] - t0) * 1000
    assert removed_ms < 100, f"removed after {removed_ms:.1f} ms"
    assert d.device_ids() == []
    print(f"\nhotplug -> added event {added_ms:.1f} ms, unplug -> removed event {removed_ms:.1f} ms")


def test_unplugged_camera_is_gone_with_its_reason_and_back_on_replug(bed, usb_daemon):
    bed.plug("root-hubs")
    d, _ = usb_daemon()
    events = TimedEvents(d)
    path = bed.plug("d435-usb2")
    assert events.expect("added", D435_ID)["json"]["arrival"] == "new"
    t0 = time.monotonic()
    bed.unplug(path)
    ev = events.expect("removed", D435_ID)
    print(f"\nunplug -> removed(unplugged) {(ev['t'] - t0) * 1000:.1f} ms")
    assert ev["json"]["reason"] == "unplugged"
    # The USB source writes the line just after it has told the table: a watcher may
    # have the event first (seen under ThreadSanitizer).
    wait_for(lambda: "usb: " + D435_ID + " left (unplugged)" in d.log(), what="the unplug logged")
    status, _, body = d.request("/v1/devices/" + D435_ID)
    assert status == 410 and json.loads(body)["gone"]["reason"] == "unplugged"
    bed.plug("d435-usb2")
    back = events.expect("added", D435_ID)["json"]
    assert back["arrival"] == "back" and back["away-since"] >= ev["json"]["last-seen"]
    h = d.get_json("/v1/devices/" + D435_ID + "/history")
    assert h["state"] == "present" and h["removals"]["unplugged"] == 1
    assert [(c["event"], c.get("reason"), c.get("arrival")) for c in h["changes"]] == [
        ("added", None, "new"), ("removed", "unplugged", None), ("added", None, "back")]


def test_recovery_device(bed, usb_daemon):
    bed.plug("root-hubs")
    d, _ = usb_daemon()
    events = TimedEvents(d)
    bed.plug("d4xx-recovery")
    dev = events.expect("added", "usb-0000F1234567")["json"]
    assert dev["recovery"] is True
    assert dev["name"] == "Intel RealSense D4XX Recovery"
    assert dev["product-id"] == "0ADB" and dev["product-line"] == "D400"
    assert "warnings" not in dev


def test_camera_behind_a_hub_has_its_port_path(bed, usb_daemon):
    bed.plug("root-hubs")
    bed.plug("hub-usb3")
    bed.plug("d405-behind-hub")
    d, _ = usb_daemon()
    dev = wait_for(lambda: usb_devices(d).get("usb-130322272121"), 5, what="the D405 listed")
    assert dev["usb"]["port-path"] == "2-3.4"
    assert dev["usb"]["sysfs-path"].endswith("/usb2/2-3/2-3.4")
    assert d.device_ids() == ["usb-130322272121"]  # the hub is not listed


def test_other_intel_and_other_vendors_devices_are_ignored(bed, usb_daemon):
    bed.plug("root-hubs")
    bed.plug("intel-other")
    d, _ = usb_daemon()
    assert d.device_ids() == []
    events = TimedEvents(d)
    bed.plug("other-vendor")      # 1234:0b5c: the D455's pid, another vendor
    p = bed.plug("d455-usb3")     # events come in order: the two above were seen first
    events.expect("added", D455_ID)
    assert d.device_ids() == [D455_ID]
    bed.unplug(p)
    events.expect("removed", D455_ID)
    events.assert_quiet()


def test_unplug_removal_latency(bed, usb_daemon):
    """Hotplug-to-event latency, measured at an SSE client, over 30 plug/unplug pairs."""
    bed.plug("root-hubs")
    d, _ = usb_daemon()
    events = TimedEvents(d)
    added, removed = [], []
    for i in range(30):
        t0 = time.monotonic()
        path = bed.plug("d435-usb2", devnum=10 + i)
        added.append((events.expect("added", D435_ID)["t"] - t0) * 1000)
        t0 = time.monotonic()
        bed.unplug(path)
        removed.append((events.expect("removed", D435_ID)["t"] - t0) * 1000)
    a = record_latency("usb plug -> added event", added)
    r = record_latency("usb unplug -> removed event", removed)
    print(f"\nplug -> added: {a}\nunplug -> removed: {r}")
    assert max(removed) < 100, removed


def proc_stats(pid):
    fds = len(os.listdir(f"/proc/{pid}/fd"))
    with open(f"/proc/{pid}/status") as f:
        rss_kb = int(next(line for line in f if line.startswith("VmRSS:")).split()[1])
    with open(f"/proc/{pid}/maps") as f:
        sanitized = "libasan" in f.read()
    return fds, rss_kb, sanitized


def test_100_replugs_leave_no_stale_entry_and_no_leak(bed, usb_daemon):
    bed.plug("root-hubs")
    bed.plug("d455-usb3")
    d, _ = usb_daemon()
    events = TimedEvents(d)

    def cycles(n, first):
        for i in range(n):
            path = bed.plug("d435-usb2", devnum=10 + (first + i) % 100)  # USB addresses: 1..127
            events.expect("added", D435_ID)
            bed.unplug(path)
            events.expect("removed", D435_ID)

    # Warm-up: allocator pools, and the change log filled to its bound (4096
    # events), so that what the 100 replugs add to RSS can only be a leak.
    t0 = time.monotonic()
    cycles(2100, 10)
    warmup_s = time.monotonic() - t0
    fds0, rss0, sanitized = proc_stats(d.proc.pid)
    cycles(100, 10)
    fds1, rss1, _ = proc_stats(d.proc.pid)
    assert d.device_ids() == [D455_ID]
    assert fds1 <= fds0, (fds0, fds1)
    if not sanitized:  # ASan's quarantine makes RSS meaningless; LSan checks at exit instead
        assert rss1 - rss0 < 256, f"RSS grew {rss1 - rss0} KiB over 100 replugs"
    print(f"\n100 replugs: fds {fds0}->{fds1}, RSS {rss0}->{rss1} KiB (sanitized: {sanitized}); "
          f"2100 warm-up replugs took {warmup_s:.1f} s")
    # Exit code 0 after SIGTERM is checked by the fixture (LSan reports leaks there).


def test_same_serial_on_usb_and_dds_is_one_camera(bed, usb_daemon, realdds_server):
    bed.plug("root-hubs")
    usb_path = bed.plug("d455-usb3")
    d, domain = usb_daemon()
    assert d.device_ids() == [D455_ID]
    info = device_info(0, serial=D455_SERIAL)
    server = realdds_server(domain, [info], name="usb-merge-server")

    def merged():
        devs = d.devices()
        return devs if len(devs) == 1 and devs[0].get("sources") == ["dds", "usb"] else None

    [dev] = wait_for(merged, 15, what="one entry with both sources")
    dds_id = dev["id"]
    assert dds_id.startswith(f"dds-{domain}-")
    assert dev["source"] == "dds"
    assert dev["topic-root"] == info["topic-root"] and dev["domain"] == domain
    assert dev["serial"] == D455_SERIAL
    assert dev["usb"]["port-path"] == "2-1"
    assert d.device_ids("?source=usb") == [dds_id]
    assert d.device_ids("?source=dds") == [dds_id]
    assert d.get_json("/v1/devices/" + D455_ID)["id"] == dds_id  # the USB id still finds it

    events = TimedEvents(d)
    bed.unplug(usb_path)  # the DDS side stays
    ev = events.expect("changed", dds_id)
    assert ev["json"]["sources"] == ["dds"] and "usb" not in ev["json"]
    assert d.device_ids() == [dds_id]
    assert d.device_ids("?source=usb") == []

    bed.plug("d455-usb3", devnum=9)  # back on USB: merged again
    ev = events.expect("changed", dds_id)
    assert ev["json"]["sources"] == ["dds", "usb"] and ev["json"]["usb"]["address"] == 9

    server.command(cmd="disconnect", **{"topic-root": info["topic-root"]})  # the USB side stays
    events.expect("removed", dds_id)
    ev = events.expect("added", D455_ID)
    assert ev["json"]["sources"] == ["usb"] and ev["json"]["source"] == "usb"
    assert "domain" not in ev["json"]
    assert d.device_ids() == [D455_ID]
    server.quit()


def test_different_serials_are_never_merged(bed, usb_daemon, realdds_server):
    bed.plug("root-hubs")
    bed.plug("d455-usb3")
    d, domain = usb_daemon()
    # Same model, a serial that differs only by its last digit: two cameras.
    realdds_server(domain, [device_info(0, serial=D455_SERIAL[:-1] + "3")])
    wait_for(lambda: len(d.devices()) == 2, 15, what="the DDS device listed next to the USB one")
    by_source = {dev["source"]: dev for dev in d.devices()}
    assert by_source["usb"]["id"] == D455_ID and by_source["usb"]["sources"] == ["usb"]
    assert by_source["dds"]["sources"] == ["dds"] and "usb" not in by_source["dds"]


def test_no_usb_flag_and_config(bed, usb_daemon, tmp_path):
    bed.plug("root-hubs")
    bed.plug("d455-usb3")
    d, _ = usb_daemon(extra=["--no-usb"])
    config = tmp_path / "config.json"
    config.write_text(json.dumps({"usb": False}))
    d2, _ = usb_daemon(extra=["--config", str(config)])
    assert d.device_ids() == [] and d2.device_ids() == []
    assert "usb:" not in d.log() and "usb:" not in d2.log()
    assert d.get_json("/healthz")["usb"] == {"state": "off"} == d2.get_json("/healthz")["usb"]


def test_reload_turns_usb_off_and_on_live(bed, usb_daemon, tmp_path):
    """`"usb": false` then `true` in the config file, each applied by SIGHUP (systemctl
    reload): the USB cameras leave the table and come back, without a restart."""
    bed.plug("root-hubs")
    bed.plug("d455-usb3")
    config = tmp_path / "config.json"
    config.write_text(json.dumps({"usb": True}))
    d, _ = usb_daemon(extra=["--config", str(config)])
    wait_for(lambda: d.device_ids() == [D455_ID], 5, what="the D455 listed")
    events = TimedEvents(d)

    config.write_text(json.dumps({"usb": False}))
    hup = time.monotonic()
    d.signal(signal.SIGHUP)
    gone = events.expect("removed", D455_ID)
    print(f"\nreload (usb off) -> removed(domain-left): {time.monotonic() - hup:.3f} s")
    assert gone["json"]["reason"] == "domain-left", gone  # left by the reload, not unplugged
    wait_for(lambda: d.get_json("/healthz")["usb"] == {"state": "off"}, 5, what="/healthz usb off")
    assert d.device_ids() == []
    assert "rsd_usb_devices" not in d.request("/metrics")[2].decode()
    # Off means not watched: a camera plugged in meanwhile is not listed...
    d435 = bed.plug("d435-usb2")
    wait_for(lambda: "reload applied: USB no longer watched" in d.log(), 5, what="the reload logged")
    assert d.device_ids() == []

    config.write_text(json.dumps({"usb": True}))
    d.signal(signal.SIGHUP)
    # ...and on again, every camera present is listed, then hotplug is followed again.
    back = {events.next()["json"]["id"], events.next()["json"]["id"]}
    assert back == {D455_ID, D435_ID}
    wait_for(lambda: d.get_json("/healthz")["usb"] == {"state": "hotplug", "devices": 2}, 5,
             what="/healthz usb watched again")
    assert d.device_ids() == sorted([D455_ID, D435_ID])
    bed.unplug(d435)
    events.expect("removed", D435_ID)
    assert d.get_json("/healthz")["usb"] == {"state": "hotplug", "devices": 1}
    log = d.log()
    assert "reload applied: USB watched" in log
    assert "takes effect on restart" not in log
    events.close()


def test_without_usb_access_logs_one_line_and_serves_dds(bed, usb_daemon, realdds_server):
    # An empty bus: no /dev/bus/usb at all, as in a container without USB passed in.
    d, domain = usb_daemon()
    lines = [line for line in d.log().splitlines() if "usb: " in line]
    assert len(lines) == 1 and "not listed" in lines[0] and "/dev/bus/usb" in lines[0], lines
    usb = d.get_json("/healthz")["usb"]
    assert usb["state"] == "unavailable" and "/dev/bus/usb" in usb["error"], usb
    realdds_server(domain, [device_info(1)])
    wait_for(lambda: d.device_ids("?source=dds"), 15, what="DDS discovery still working")


def test_polling_fallback(bed, usb_daemon):
    bed.plug("root-hubs")
    d, _ = usb_daemon(env={"RSD_USB_FORCE_POLLING": "1", "RSD_USB_POLL_MS": "100"})
    assert "re-enumerating every 100 ms" in d.log()
    events = TimedEvents(d)
    path = bed.plug("d435-usb2")
    assert events.expect("added", D435_ID, timeout=3)["json"]["usb"]["speed"] == "high"
    bed.unplug(path)
    events.expect("removed", D435_ID, timeout=3)


def test_sigterm_stops_promptly_with_usb_watching(bed, usb_daemon):
    bed.plug("root-hubs")
    bed.plug("d455-usb3")
    d, _ = usb_daemon()
    t0 = time.monotonic()
    d.proc.send_signal(signal.SIGTERM)
    d.proc.wait(5)
    assert time.monotonic() - t0 < 1.0
    assert d.proc.returncode == 0, d.log()[-2000:]


def test_device_nodes_of_a_camera_and_of_its_bound_interfaces(bed, usb_daemon):
    # What `rs-discover clients` looks for among processes' open files.
    bed.plug("root-hubs")
    bed.plug("d455-uvc")
    d, _ = usb_daemon()
    dev = wait_for(lambda: usb_devices(d).get(D455_ID), 5, what="the D455 listed")
    nodes = wait_for(lambda: (lambda n: n if "/dev/video0" in n else None)(
        usb_devices(d)[D455_ID]["usb"].get("device-nodes", [])), 5, what="its video node")
    assert nodes == ["/dev/bus/usb/002/002", "/dev/media0", "/dev/video0"], dev
