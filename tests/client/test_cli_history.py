"""rs-discover history and get against the real daemon and a realdds server: a camera
that left is `gone` with its reason, one never seen is not found."""
import json

from client_util import rs_discover
from conftest import device_info, wait_for


def one_camera(daemon, realdds_server, domain, n, server_name):
    """A daemon on `domain` listing camera `n` of a realdds server of its own:
    (daemon, its endpoint, the device-info, the server, the camera's id)."""
    d = daemon([domain])
    info = device_info(n)
    server = realdds_server(domain, [info], name=server_name)
    wait_for(lambda: len(d.device_ids()) == 1, timeout=20, what="the camera listed")
    return d, "unix:" + d.socket, info, server, d.device_ids()[0]


def test_history_and_get_tell_gone_from_never_seen(daemon, realdds_server, free_domain):
    d, ep, info, server, device_id = one_camera(daemon, realdds_server, free_domain, 1, "history-cli")
    server.command(cmd="disconnect", **{"topic-root": info["topic-root"]})  # 'stopping'
    wait_for(lambda: d.device_ids() == [], timeout=20, what="the camera removed")

    r = rs_discover("get", info["serial"], endpoint=ep)
    assert r.returncode == 1 and "is gone (stopping" in r.stderr, r.stderr
    r = rs_discover("get", "never-seen", endpoint=ep)
    assert r.returncode == 1 and "no device 'never-seen'" in r.stderr and "gone" not in r.stderr, r.stderr

    r = rs_discover("history", device_id, endpoint=ep)
    assert r.returncode == 0, r.stderr
    assert f"{device_id}: gone" in r.stdout and "removals: stopping=1" in r.stdout
    assert "removed: stopping" in r.stdout, r.stdout
    doc = json.loads(rs_discover("history", info["serial"], "--json", endpoint=ep).stdout)
    assert doc["state"] == "gone" and doc["gone"]["reason"] == "stopping"
    r = rs_discover("history", "never-seen", endpoint=ep)
    assert r.returncode == 1, (r.returncode, r.stderr)

    whole = rs_discover("history", endpoint=ep)
    assert whole.returncode == 0 and whole.stdout.count(device_id) == 2, whole.stdout

    # It said 'stopping': the doctor names it, as no fault (a camera lost by its lease is
    # a warn: test_removal_reasons.py).
    r = rs_discover("doctor", "--listen", "0", endpoint=ep)
    gone_lines = [line for line in r.stdout.splitlines() if line.split()[:2] == ["info", "gone"]]
    assert gone_lines and device_id in gone_lines[0] and "stopping" in gone_lines[0], r.stdout


def test_doctor_names_a_flapping_camera_and_its_host(daemon, realdds_server, free_domain):
    # Its server killed (its lease runs out: lease-expired) and started again at once:
    # the camera is back within a minute of its removal, a flap.
    d, ep, info, server, device_id = one_camera(daemon, realdds_server, free_domain, 2, "flapping-host")
    address = d.get_json(f"/v1/devices/{device_id}")["server"]["addresses"][0]
    server.kill()
    wait_for(lambda: d.device_ids() == [], timeout=15, what="the camera removed by its lease")
    realdds_server(free_domain, [info], name="flapping-host")
    wait_for(lambda: d.device_ids() == [device_id], timeout=20, what="the camera back")
    hist = d.get_json(f"/v1/devices/{device_id}/history")
    assert hist["flaps"] == 1 and hist["removals"].get("lease-expired") == 1, hist

    r = rs_discover("doctor", "--listen", "0", endpoint=ep)
    flap_lines = [line for line in r.stdout.splitlines() if line.split()[:2] == ["warn", "flaps"]]
    assert len(flap_lines) == 1, r.stdout
    assert device_id in flap_lines[0] and "1 time" in flap_lines[0], flap_lines
    # Named by the host it is on: its server's name and address.
    assert f"server 'flapping-host' at {address}" in flap_lines[0], flap_lines
