"""Each way a realdds camera leaves (librealsense's own realdds server, pyrealdds on
Fast DDS) is told by its own reason: in the `removed` event, the camera's history,
its gone answer (410) and /metrics. Times from the event to the verdict are printed
for the report."""
import json
import os
import signal
import subprocess
import time
import urllib.parse

from conftest import EventStream, device_info, wait_for

CLI = os.path.join(os.environ.get("RSD_BUILD_DIR", ""), "client", "rs-discover")
LEASE_S = 3.0  # realdds participants announce a 3 s lease
LEASE_MARGIN_S = 4.0  # re-announce period, Cyclone's lease check and a loaded machine


def dds_id(domain, info):
    return f"dds-{domain}-" + info["topic-root"].replace("/", ".")


def removed_within(events, device_id, timeout, since=None):
    """The removed event, and its time (as read) from `since` (the cause: taken before
    the command that causes it, whose reply may come after the event), else from now."""
    start = time.monotonic() if since is None else since
    while True:
        ev = events.next(timeout=max(0.1, timeout - (time.monotonic() - start)))
        if ev["event"] == "removed" and ev["json"]["id"] == device_id:
            return ev, ev.get("t", time.monotonic()) - start


def check_gone(d, device_id, info, reason):
    hist = d.get_json(f"/v1/devices/{device_id}/history")
    assert hist["state"] == "gone" and hist["gone"]["reason"] == reason, hist
    assert [c["event"] for c in hist["changes"]][-2:] == ["added", "removed"], hist
    assert hist["changes"][-1]["reason"] == reason
    assert hist["removals"][reason] == 1
    # By serial too, and a camera never seen is not gone.
    by_serial = d.get_json(f"/v1/devices/{info['serial']}/history")
    assert by_serial["id"] == device_id


def test_stopping_writer_gone_and_kill_each_have_their_reason(free_domain, daemon, realdds_server):
    dom = free_domain
    a, b, c = device_info(1), device_info(2), device_info(3)
    server = realdds_server(dom, [a, b], name="bench-a")
    killed = realdds_server(dom, [c], name="bench-c")
    d = daemon([dom])
    wait_for(lambda: len(d.devices()) == 3, what="three devices")
    events = EventStream(d)

    since = time.monotonic()
    server.command(cmd="disconnect", **{"topic-root": a["topic-root"]})  # 'stopping'
    ev, took = removed_within(events, dds_id(dom, a), 10, since)
    assert ev["json"]["reason"] == "stopping"
    print(f"stopping -> removed(stopping): {took:.3f} s")
    check_gone(d, dds_id(dom, a), a, "stopping")

    since = time.monotonic()
    server.command(cmd="remove", **{"topic-root": b["topic-root"]})  # its DataWriter is deleted
    ev, took = removed_within(events, dds_id(dom, b), 10, since)
    assert ev["json"]["reason"] == "writer-gone"
    print(f"writer deleted -> removed(writer-gone): {took:.3f} s")
    check_gone(d, dds_id(dom, b), b, "writer-gone")

    killed.kill()  # SIGKILL: only its lease tells
    ev, took = removed_within(events, dds_id(dom, c), LEASE_S + LEASE_MARGIN_S)
    assert ev["json"]["reason"] == "lease-expired"
    print(f"SIGKILL -> removed(lease-expired): {took:.3f} s")
    check_gone(d, dds_id(dom, c), c, "lease-expired")

    status = d.request(f"/v1/devices/{urllib.parse.quote(c['topic-root'], safe='')}")[0]
    assert status == 410
    assert d.request("/v1/devices/never-seen")[0] == 404
    m = d.request("/metrics")[2].decode()
    for reason in ("stopping", "writer-gone", "lease-expired"):
        assert f'rsd_device_removals_total{{reason="{reason}"}} 1' in m, m
    log = d.log()
    assert "removed (lease-expired)" in log and "removed (stopping)" in log and "removed (writer-gone)" in log

    # The doctor names the camera lost by its lease as a warn (it explains a missing
    # camera), those its server closed ('stopping', its writer deleted) as info.
    r = subprocess.run([CLI, "--endpoint", "unix:" + d.socket, "doctor", "--listen", "0", "--json"],
                       capture_output=True, text=True, timeout=60)
    gone = {f["text"].split()[0]: f["verdict"] for f in json.loads(r.stdout)["findings"] if f["topic"] == "gone"}
    assert gone == {dds_id(dom, a): "info", dds_id(dom, b): "info", dds_id(dom, c): "warn"}, gone

    # The killed server back: `added` says it is back, after how long away.
    again = realdds_server(dom, [c], name="bench-c")
    while True:
        ev = events.next(timeout=30)
        if ev["event"] == "added" and ev["json"]["id"] == dds_id(dom, c):
            break
    assert ev["json"]["arrival"] == "back" and ev["json"]["away-since"]
    events.close()
    again.quit()


def test_a_reload_lowering_a_device_cap_refuses_the_newest(free_domain, daemon, realdds_server, tmp_path):
    """`refused`: a reload lowers max-devices-per-participant, then max-devices-per-domain.
    The devices found last leave, each with its reason; those found first stay."""
    dom = free_domain
    config = tmp_path / "config.json"
    config.write_text(json.dumps({"domains": [dom]}))
    d = daemon([dom], http=False, extra=["--config", str(config)])
    events = EventStream(d)
    a, b, c = device_info(1), device_info(2), device_info(3)
    two = realdds_server(dom, [a, b], name="bench-two")
    one = realdds_server(dom, [c], name="bench-one")
    found = []
    while len(found) < 3:
        ev = events.next(timeout=30)
        if ev["event"] == "added":
            found.append(ev["json"]["id"])
    ids = {dds_id(dom, i) for i in (a, b, c)}
    assert set(found) == ids

    # One device per participant: of bench-two's pair, the one found later goes.
    pair = [i for i in found if i in {dds_id(dom, a), dds_id(dom, b)}]
    config.write_text(json.dumps({"domains": [dom], "max-devices-per-participant": 1}))
    d.proc.send_signal(signal.SIGHUP)
    ev, took = removed_within(events, pair[1], 10)
    assert ev["json"]["reason"] == "refused", ev
    print(f"reload (per-participant cap 1) -> removed(refused): {took:.3f} s")
    assert sorted(d.device_ids()) == sorted(ids - {pair[1]})

    # One device per domain: of the two left, the one found later goes.
    left = [i for i in found if i != pair[1]]
    config.write_text(json.dumps({"domains": [dom], "max-devices-per-domain": 1,
                                  "max-devices-per-participant": 1}))
    d.proc.send_signal(signal.SIGHUP)
    ev, took = removed_within(events, left[1], 10)
    assert ev["json"]["reason"] == "refused", ev
    print(f"reload (domain cap 1) -> removed(refused): {took:.3f} s")
    assert d.device_ids() == [left[0]]

    hist = d.get_json(f"/v1/devices/{left[1]}/history")
    assert hist["state"] == "gone" and hist["gone"]["reason"] == "refused", hist
    assert "max-devices-per-domain is now 1" in hist["changes"][-1]["detail"], hist
    assert 'rsd_device_removals_total{reason="refused"} 2' in d.request("/metrics")[2].decode()
    log = d.log()
    assert "removed (refused): max-devices-per-participant is now 1" in log
    assert "device caps now 1 per participant, 1 per domain" in log
    # The cap holds after the reload too: made anew (SIGUSR1), the participant hears
    # every server announce again, and what the caps refused is counted, not listed.
    def over_caps():
        r = d.get_json("/v1/domains")["domains"][0]["rejected"]
        return r.get("domain-device-limit", 0) + r.get("participant-device-limit", 0)
    before = over_caps()
    d.proc.send_signal(signal.SIGUSR1)
    wait_for(lambda: over_caps() >= before + 2, timeout=20, what="the refused devices announced again, refused")
    assert d.device_ids() == [left[0]]
    events.close()
    two.quit()
    one.quit()
