"""Returns after a lease lost on a lossy link, one after another: a realdds D555 behind
30 % random UDP loss (network namespaces, nftables), and a 4 s cut on top of it each
turn, longer than realdds' 3 s lease. Each turn the daemon removes the camera
(`lease-expired`), hears its server again once the cut heals, and lists the camera
again, however many refreshes came before: one refresh per loss at most.

Printed: for each turn, the time from the heal to the server heard again and from
heard to listed again (the issue asks 2 s for the latter; the peer's endpoint repair
on a lossy link decides the tail: docs/history.md, "A lossy link"). The suite runs 3
turns; the note's distribution: RSD_RETURN_TURNS=24.
"""
import os
import statistics
import time

from conftest import wait_for
from netns import two_hosts  # noqa: F401 (a fixture)
from test_realdds import dds_id

TURNS = int(os.environ.get("RSD_RETURN_TURNS", "3"))
CUT_S = 4.0
INFO = {"name": "Intel RealSense D555", "serial": "555000139", "product-line": "D500", "product-id": "0B56",
        "fw-version": "7.56.19829.840", "topic-root": "realsense/D555_555000139"}


def test_each_loss_returns(free_domain, daemon, realdds_server, two_hosts):
    net, dom = two_hosts, free_domain
    server = realdds_server(dom, [], name="returning-server", prefix=net.prefix(net.camera))
    server.command(cmd="add", info=INFO, spec="d555")
    d = daemon([dom], http=False, prefix=net.prefix(net.host))
    cam = dds_id(dom, INFO)
    wait_for(lambda: d.device_ids() == [cam], timeout=20, what="the camera")

    def heard():
        return any(p["name"] == "returning-server" and p["state"] == "alive"
                   for p in d.get_json("/v1/participants")["participants"])

    refreshes_before = d.get_json("/v1/domains")["domains"][0]["refreshes"]
    turns = []
    for _ in range(TURNS):
        net.lose(30)
        net.cut()
        cut_at = time.monotonic()
        wait_for(lambda: d.device_ids() == [], timeout=15, what="the camera removed by the cut")
        while time.monotonic() < cut_at + CUT_S:
            time.sleep(0.02)
        net.heal()  # the 30 % loss stays: the return is made on it
        healed_at, heard_at = time.monotonic(), None
        while d.device_ids() != [cam]:
            assert time.monotonic() < healed_at + 30, f"not listed again 30 s after the heal: {d.log()[-3000:]}"
            if heard_at is None and heard():
                heard_at = time.monotonic()
            time.sleep(0.05)
        back = time.monotonic()
        heard_at = min(heard_at or back, back)  # heard after it was back: the poll saw it late
        turns.append((round(heard_at - healed_at, 2), round(back - heard_at, 2)))
        net.unlose()
        time.sleep(2)  # a clean link between turns: each turn starts from a listed camera

    hist = d.get_json(f"/v1/devices/{cam}/history")
    assert hist["removals"].get("lease-expired", 0) == TURNS, hist
    refreshes = d.get_json("/v1/domains")["domains"][0]["refreshes"] - refreshes_before
    assert refreshes <= TURNS, (refreshes, TURNS)  # one per loss at most: none wasted on a lossy link
    listed = sorted(t[1] for t in turns)
    print(f"\n{TURNS} turns (heal to heard s, heard to listed s): {turns}\n"
          f"heard to listed: median {statistics.median(listed):.2f} s, max {listed[-1]:.2f} s, "
          f"{sum(1 for t in listed if t <= 2.0)} of {TURNS} within 2 s; {refreshes} refreshes")
    server.quit()
