"""The daemon against librealsense's own realdds stack (pyrealsense2.pyrealdds on
Fast DDS): what a networked RealSense camera announces is what users list."""
import signal
import time

from conftest import EventStream, device_info, wait_for

LEASE_S = 3.0  # realdds participants announce a 3 s lease
LEASE_MARGIN_S = 3.0  # re-announce period, Cyclone's lease check and a loaded CI machine


def dds_id(domain, info):
    return f"dds-{domain}-" + info["topic-root"].replace("/", ".")


def test_lists_devices_with_every_field(free_domain, daemon, realdds_server):
    infos = [device_info(1), device_info(2, recovery=False, **{"multicast-ip": "239.255.0.1"})]
    server = realdds_server(free_domain, infos, name="lab-bench-7")
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 2, what="both devices listed")
    by_id = {dev["id"]: dev for dev in d.devices()}
    for info in infos:
        dev = by_id[dds_id(free_domain, info)]
        for key, value in info.items():  # every device-info field, verbatim
            assert dev[key] == value, key
        assert dev["source"] == "dds"
        assert dev["domain"] == free_domain
        assert dev["recovery"] is False
        assert dev["first-seen"] and dev["last-seen"]
        assert dev["server"]["participant-name"] == "lab-bench-7"
        assert len(dev["server"]["participant-guid"]) == 35
        assert dev["server"]["addresses"], "the camera's IP address"
    # One device by id, on both transports; the id is URL-safe as it stands.
    one = dds_id(free_domain, infos[0])
    assert d.get_json(f"/v1/devices/{one}")["serial"] == infos[0]["serial"]
    assert d.get_json(f"/v1/devices/{one}", via="tcp")["serial"] == infos[0]["serial"]
    server.quit()


def test_stopping_message_removes_only_that_device(free_domain, daemon, realdds_server):
    a, b = device_info(1), device_info(2)
    server = realdds_server(free_domain, [a, b])
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 2, what="two devices")
    events = EventStream(d)
    server.command(cmd="disconnect", **{"topic-root": a["topic-root"]})
    ev = events.next()
    assert ev["event"] == "removed" and ev["json"]["id"] == dds_id(free_domain, a)
    assert d.device_ids() == [dds_id(free_domain, b)]
    assert d.get_json("/v1/domains")["domains"][0]["stopping"] == 1
    events.close()


def test_writer_going_away_removes_the_device(free_domain, daemon, realdds_server):
    a, b = device_info(1), device_info(2)
    server = realdds_server(free_domain, [a, b])
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 2, what="two devices")
    server.command(cmd="remove", **{"topic-root": a["topic-root"]})  # its DataWriter is deleted
    wait_for(lambda: d.device_ids() == [dds_id(free_domain, b)], what="only the remaining device")


def test_server_exit_removes_its_devices(free_domain, daemon, realdds_server):
    server = realdds_server(free_domain, [device_info(1), device_info(2)])
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 2, what="two devices")
    server.quit()
    wait_for(lambda: d.devices() == [], what="no devices after the server exits")


def test_killed_server_vanishes_within_lease_and_comes_back(free_domain, daemon, realdds_server):
    info = device_info(1)
    server = realdds_server(free_domain, [info])
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 1, what="device listed")
    events = EventStream(d)
    killed = time.monotonic()
    server.kill()
    ev = events.next(timeout=LEASE_S + LEASE_MARGIN_S)
    assert ev["event"] == "removed", ev
    elapsed = time.monotonic() - killed
    assert elapsed < LEASE_S + LEASE_MARGIN_S
    print(f"removal after SIGKILL: {elapsed:.2f}s")
    # The camera reboots: the same device is added again, with the same id.
    realdds_server(free_domain, [info])
    ev = events.next(timeout=15)
    assert ev["event"] == "added" and ev["json"]["id"] == dds_id(free_domain, info)
    events.close()


def test_two_domains_watched_and_an_unconfigured_one_ignored(domains, daemon, realdds_server):
    a, b, c = domains.take(), domains.take(), domains.take()
    realdds_server(a, [device_info(1)])
    realdds_server(b, [device_info(2)])
    realdds_server(c, [device_info(3)])
    d = daemon([a, b])
    wait_for(lambda: len(d.devices()) == 2, what="devices of both watched domains")
    assert {dev["domain"] for dev in d.devices()} == {a, b}
    assert [dev["domain"] for dev in d.devices(f"?domain={b}")] == [b]
    assert sorted(s["domain"] for s in d.get_json("/v1/domains")["domains"]) == sorted([a, b])
    # Domain c's camera announces itself to us too; give it the time a watched one takes.
    realdds_server(a, [device_info(4)])
    wait_for(lambda: len(d.devices()) == 3, what="a later device on a watched domain")
    assert c not in {dev["domain"] for dev in d.devices()}


def test_two_servers_with_several_devices_each(free_domain, daemon, realdds_server):
    first = [device_info(n) for n in range(1, 4)]
    second = [device_info(n) for n in range(4, 7)]
    d = daemon([free_domain])
    s1 = realdds_server(free_domain, first, name="server-one")
    s2 = realdds_server(free_domain, second, name="server-two")
    wait_for(lambda: len(d.devices()) == 6, what="six devices from two servers")
    names = {dev["topic-root"]: dev["server"]["participant-name"] for dev in d.devices()}
    assert all(names[i["topic-root"]] == "server-one" for i in first)
    assert all(names[i["topic-root"]] == "server-two" for i in second)
    s1.quit()
    wait_for(lambda: len(d.devices()) == 3, what="the second server's devices only")
    assert {dev["server"]["participant-name"] for dev in d.devices()} == {"server-two"}
    s2.quit()


def test_sse_added_removed_and_resume_with_last_event_id(free_domain, daemon, realdds_server):
    d = daemon([free_domain])
    events = EventStream(d)
    info = device_info(1)
    server = realdds_server(free_domain, [info])
    added = events.next(timeout=15)
    assert added["event"] == "added" and added["json"]["serial"] == info["serial"]
    events.close()
    # While no client listens, the device goes and another comes.
    server.command(cmd="disconnect", **{"topic-root": info["topic-root"]})
    other = device_info(2)
    server.command(cmd="add", info=other)
    wait_for(lambda: d.device_ids() == [dds_id(free_domain, other)], what="the second device only")
    resumed = EventStream(d, last_event_id=added["id"])
    missed = [resumed.next(), resumed.next()]
    assert [(e["event"], e["json"]["id"]) for e in missed] == [
        ("removed", dds_id(free_domain, info)), ("added", dds_id(free_domain, other))]
    assert int(missed[0]["id"]) > int(added["id"]) and int(missed[1]["id"]) > int(missed[0]["id"])
    resumed.close()


def test_rebuilding_the_participant_keeps_devices_without_events(free_domain, daemon, realdds_server):
    a, b = device_info(1), device_info(2)
    server = realdds_server(free_domain, [a, b])
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 2, what="two devices")
    events = EventStream(d)
    before = d.get_json("/v1/domains")["domains"][0]
    d.signal(signal.SIGUSR1)  # a fresh participant, as after a network cut
    wait_for(lambda: d.get_json("/v1/domains")["domains"][0]["rebuilds"] == 1, what="rebuild counted")
    after = wait_for(lambda: (lambda s: s if s["state"] == "running" else None)(
        d.get_json("/v1/domains")["domains"][0]), what="domain reading again")
    assert after["participant-guid"] != before["participant-guid"]
    assert len(d.devices()) == 2  # never dropped meanwhile
    # The new participant reads as soon as it knows the server's writers, not after
    # the whole settle time (1.7 s) a first join waits.
    reads = [ln for ln in d.log().splitlines() if "ms after joining" in ln]
    assert len(reads) == 2 and "every server it waits for is heard" in reads[1], reads
    assert int(reads[1].split("reading device-info ")[1].split(" ms")[0]) < 1700, reads
    # The new participant still tracks the writers: a device leaving is noticed.
    wait_for(lambda: d.get_json("/v1/domains")["domains"][0]["accepted"] > before["accepted"],
             what="device-info received again by the new participant")
    server.command(cmd="remove", **{"topic-root": a["topic-root"]})
    ev = events.next(timeout=15)
    assert ev["event"] == "removed" and ev["json"]["id"] == dds_id(free_domain, a), ev
    assert d.device_ids() == [dds_id(free_domain, b)]
    events.close()


def test_one_server_announcing_a_hundred_devices_at_once(free_domain, daemon, realdds_server):
    """Regression: a server creating many device writers in a burst raced
    Cyclone's discovery of those writers, and on a loaded machine the daemon kept
    42 of 100. Writers that match but stay silent now make the reader anew."""
    d = daemon([free_domain])
    infos = [device_info(n) for n in range(100)]
    realdds_server(free_domain, infos)
    wait_for(lambda: len(d.devices()) == 100, timeout=30, what="all 100 devices")
    assert sorted(dev["serial"] for dev in d.devices()) == sorted(i["serial"] for i in infos)


def test_device_stays_while_any_server_announces_it(free_domain, daemon, realdds_server):
    """Two servers announce one topic-root (a camera served twice, or a hand-over):
    the device lives while either's writer does, and shows a server still alive."""
    cam = device_info(1)
    older = realdds_server(free_domain, [cam], name="older-server")
    d = daemon([free_domain])
    cam_id = dds_id(free_domain, cam)
    wait_for(lambda: d.device_ids() == [cam_id], what="the camera from the older server")
    newer = realdds_server(free_domain, [cam], name="newer-server")
    wait_for(lambda: d.get_json(f"/v1/devices/{cam_id}")["server"]["participant-name"] == "newer-server",
             what="the camera shown from the newer server")
    events = EventStream(d)

    newer.kill()  # SIGKILL: noticed at its lease; the older server still serves the camera
    wait_for(lambda: d.get_json(f"/v1/devices/{cam_id}")["server"]["participant-name"] == "older-server",
             timeout=LEASE_S + LEASE_MARGIN_S, what="the camera shown from the older server")
    ev = events.next()
    assert ev["event"] == "changed" and ev["json"]["server"]["participant-name"] == "older-server", ev
    assert d.device_ids() == [cam_id]

    older.command(cmd="disconnect", **{"topic-root": cam["topic-root"]})  # the last one says 'stopping'
    ev = events.next()
    assert ev["event"] == "removed" and ev["json"]["id"] == cam_id, ev
    assert d.device_ids() == []
    events.close()
    older.quit()
