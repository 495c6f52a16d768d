"""Hung or gone: when a realdds server on another host (network namespaces on one
bridge, a switch) is lost by its lease, the daemon probes its host and says which.

- SIGSTOP the server: its host's kernel still answers, so the removal
  (`lease-expired`) is judged `host-present` (the server hung).
- Pull the camera's cable at the switch (its port on the bridge deleted): nothing
  answers, so the removal is judged `host-unreachable`.

The verdict is in the removal's history record, the gone answer, the log and
/metrics; the time from the removed event to the verdict is printed for the note."""
import json
import os
import signal
import subprocess
import time

import pytest

from conftest import EventStream, device_info, wait_for
from netns import Lan
from test_removal_reasons import LEASE_MARGIN_S, LEASE_S, dds_id, removed_within

CLI = os.path.join(os.environ.get("RSD_BUILD_DIR", ""), "client", "rs-discover")
VERDICT_WITHIN_S = 30.0  # bounds a failure only: ARP gives up after a few seconds


@pytest.fixture
def lan():
    net = Lan(2)  # host 0: the daemon; host 1: the camera
    yield net
    net.destroy()


def removed_and_judged(d, events, device_id):
    ev, took = removed_within(events, device_id, LEASE_S + LEASE_MARGIN_S)
    assert ev["json"]["reason"] == "lease-expired", ev
    removed_at = time.monotonic()

    def verdict():
        changes = d.get_json(f"/v1/devices/{device_id}/history")["changes"]
        return changes[-1].get("host-check") if changes[-1]["event"] == "removed" else None

    v = wait_for(verdict, timeout=VERDICT_WITHIN_S, interval=0.05, what="a verdict on the host")
    return v, took, time.monotonic() - removed_at


def start(lan, free_domain, daemon, realdds_server):
    cam = device_info(31)
    server = realdds_server(free_domain, [cam], name="poe-camera", prefix=lan.prefix(1))
    d = daemon([free_domain], http=False, prefix=lan.prefix(0))
    wait_for(lambda: d.device_ids() == [dds_id(free_domain, cam)], timeout=15, what="the camera listed")
    return cam, server, d


def doctor_says(d, device_id):
    r = subprocess.run([CLI, "--endpoint", "unix:" + d.socket, "doctor", "--listen", "0", "--json"],
                       capture_output=True, text=True, timeout=60)
    found = [f for f in json.loads(r.stdout)["findings"] if f["topic"] == "gone" and f["text"].startswith(device_id)]
    assert len(found) == 1, r.stdout
    return found[0]


def test_a_hung_server_on_a_live_host_is_judged_present(lan, free_domain, daemon, realdds_server):
    cam, server, d = start(lan, free_domain, daemon, realdds_server)
    events = EventStream(d)
    server.proc.send_signal(signal.SIGSTOP)  # the process hangs; its host's kernel runs on
    try:
        verdict, lease, judged = removed_and_judged(d, events, dds_id(free_domain, cam))
    finally:
        server.proc.send_signal(signal.SIGCONT)
    print(f"SIGSTOP -> removed(lease-expired) {lease:.3f} s, then host-present in {judged:.3f} s")
    assert verdict == "host-present"
    gone = d.request(f"/v1/devices/{dds_id(free_domain, cam)}")
    assert gone[0] == 410 and b'"host-check":"host-present"' in gone[2], gone
    assert "host-present, server 'poe-camera' at " + lan.ips[1] in d.log()
    m = d.request("/metrics")[2].decode()
    assert 'rsd_lease_expired_hosts_total{verdict="host-present"} 1' in m, m
    assert 'rsd_lease_expired_hosts_total{verdict="host-unreachable"} 0' in m, m
    said = doctor_says(d, dds_id(free_domain, cam))
    assert said["verdict"] == "warn" and "the camera's server hung (power-cycle a PoE camera)" in said["text"], said


def test_a_host_cut_off_at_the_switch_is_judged_unreachable(lan, free_domain, daemon, realdds_server):
    cam, server, d = start(lan, free_domain, daemon, realdds_server)
    events = EventStream(d)
    lan.exec(lan.switch, "ip", "link", "del", "p1")  # the camera's cable, pulled at the switch
    verdict, lease, judged = removed_and_judged(d, events, dds_id(free_domain, cam))
    print(f"link deleted -> removed(lease-expired) {lease:.3f} s, then host-unreachable in {judged:.3f} s")
    assert verdict == "host-unreachable"
    assert "host-unreachable, server 'poe-camera' at " + lan.ips[1] in d.log()
    m = d.request("/metrics")[2].decode()
    assert 'rsd_lease_expired_hosts_total{verdict="host-unreachable"} 1' in m, m
    assert 'rsd_lease_expired_hosts_total{verdict="host-present"} 0' in m, m
    said = doctor_says(d, dds_id(free_domain, cam))
    assert "check the cable, the switch or the power" in said["text"], said
