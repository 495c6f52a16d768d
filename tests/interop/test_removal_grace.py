"""removal-grace: a realdds camera whose server's lease ran out (its process
SIGSTOPped: silent, as on a lossy link or a stalled server) stays listed, marked
`unresponsive`, for the grace; heard again within it (SIGCONT) it is never removed
and the mark goes; not heard again, it is removed with `lease-expired` once the grace
is over. Default (0): removed at once, as librealsense does."""
import signal
import time

from conftest import EventStream, device_info, wait_for
from test_removal_reasons import LEASE_MARGIN_S, LEASE_S, dds_id


def next_about(events, device_id, timeout):
    deadline = time.monotonic() + timeout
    while True:
        ev = events.next(timeout=max(0.1, deadline - time.monotonic()))
        if ev["event"] != "resync" and ev["json"]["id"] == device_id:
            return ev


def stalled(free_domain, daemon, realdds_server, n, grace):
    """A camera listed, then its server SIGSTOPped until the camera is marked."""
    cam = device_info(n)
    server = realdds_server(free_domain, [cam], name=f"stalling-{n}")
    d = daemon([free_domain], extra=["--removal-grace", str(grace)])
    dev = dds_id(free_domain, cam)
    wait_for(lambda: d.device_ids() == [dev], timeout=15, what="the camera listed")
    events = EventStream(d)
    server.proc.send_signal(signal.SIGSTOP)
    ev = next_about(events, dev, LEASE_S + LEASE_MARGIN_S)
    assert ev["event"] == "changed" and ev["json"].get("unresponsive") is True, ev
    return server, d, dev, events


def test_heard_again_within_the_grace_is_never_removed(free_domain, daemon, realdds_server):
    server, d, dev, events = stalled(free_domain, daemon, realdds_server, 41, 30)
    try:
        assert d.get_json(f"/v1/devices/{dev}")["unresponsive"] is True
    finally:
        server.proc.send_signal(signal.SIGCONT)
    stalled_for = time.monotonic()
    ev = next_about(events, dev, 30)
    back = time.monotonic() - stalled_for
    print(f"SIGCONT -> listed without the mark in {back:.3f} s")
    assert ev["event"] == "changed" and "unresponsive" not in ev["json"], ev
    hist = d.get_json(f"/v1/devices/{dev}/history")
    assert [c["event"] for c in hist["changes"]] == ["added"], hist  # never removed
    assert "heard again within the removal grace" in d.log()


def test_not_heard_again_is_removed_when_the_grace_ends(free_domain, daemon, realdds_server):
    server, d, dev, events = stalled(free_domain, daemon, realdds_server, 42, 4)
    marked = time.monotonic()
    try:
        ev = next_about(events, dev, 4 + 5)
        grace = time.monotonic() - marked
        print(f"unresponsive -> removed(lease-expired) after {grace:.3f} s (grace 4 s)")
        assert ev["event"] == "removed" and ev["json"]["reason"] == "lease-expired", ev
        assert grace >= 3.5, grace  # not before its grace (the tick's 250 ms aside)
    finally:
        server.proc.send_signal(signal.SIGCONT)


def test_without_the_grace_no_camera_is_marked(free_domain, daemon, realdds_server):
    cam = device_info(43)
    server = realdds_server(free_domain, [cam], name="killed")
    d = daemon([free_domain])
    dev = dds_id(free_domain, cam)
    wait_for(lambda: d.device_ids() == [dev], timeout=15, what="the camera listed")
    events = EventStream(d)
    server.kill()
    ev = next_about(events, dev, LEASE_S + LEASE_MARGIN_S)
    assert ev["event"] == "removed" and ev["json"]["reason"] == "lease-expired", ev
