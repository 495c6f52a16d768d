"""Camera Discovery, complete: GET /v1/devices/{id}/description against real realdds
servers (pyrealsense2's pyrealdds), and against made-up servers (PyPI cyclonedds
writing the notification topic) for what a real one never does on purpose: never
answering, never finishing a set, sending garbage."""
import json
import os
import subprocess
import sys
import threading
import time

import pytest

from camera_spec import SPEC, TYPE, WIRE_FORMAT
from conftest import EventStream, device_info, wait_for
from test_realdds import dds_id

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "api"))
from api_util import spec  # noqa: E402  (the spec checks live with the API tests)
from openapi_schema_validator import OAS30Validator  # noqa: E402


def check_spec(status, body):
    """The real answer against proto/openapi.yaml's response for the route."""
    response = spec()["paths"]["/v1/devices/{id}/description"]["get"]["responses"][str(status)]
    schema = response["content"]["application/json"]["schema"]
    OAS30Validator({**schema, "components": spec()["components"]}).validate(body)


def describe(d, device_id, via="unix"):
    status, headers, body = d.request(f"/v1/devices/{device_id}/description", via=via, timeout=60)
    body = json.loads(body)
    check_spec(status, body)
    return status, headers, body


def subscriptions(d, topic_root):
    return d.log().count(f"subscribing to {topic_root}/notification")


def served_camera(n, domain, daemon, realdds_server, extra=()):
    """A realdds server serving camera n with SPEC, and a daemon that lists it."""
    cam = device_info(n)
    server = realdds_server(domain, [])
    server.command(cmd="add", info=cam, spec=SPEC)
    d = daemon([domain], extra=list(extra))
    cam_id = dds_id(domain, cam)
    wait_for(lambda: d.device_ids() == [cam_id], what="the camera")
    return server, d, cam, cam_id


def announce(d, writer, domain, *infos):
    """Writes the device-infos until the daemon lists them all (a just-matched
    writer's first samples can be lost to the late-joiner race)."""
    def listed():
        ids = d.device_ids()
        if all(dds_id(domain, i) in ids for i in infos):
            return True
        for i in infos:
            writer.send(json=i)
        return False
    wait_for(listed, timeout=20, interval=0.5, what="announced")


def test_description_matches_what_the_server_declared(free_domain, daemon, realdds_server):
    server, d, cam, cam_id = served_camera(1, free_domain, daemon, realdds_server)
    events = EventStream(d)
    t = time.monotonic()
    status, _, desc = describe(d, cam_id)
    print(f"first description of a {len(SPEC['streams'])}-stream server: {(time.monotonic() - t) * 1000:.1f} ms")
    assert status == 200, desc
    assert [s["name"] for s in desc["streams"]] == [s["name"] for s in SPEC["streams"]]
    for got, want in zip(desc["streams"], SPEC["streams"]):
        assert got["type"] == TYPE[want["kind"]]
        assert got["sensor-name"] == want["sensor"]
        if want["kind"] == "motion":
            assert got["profiles"] == [{"fps": p[0]} for p in want["profiles"]]
        else:
            assert got["profiles"] == [{"fps": p[0], "format": WIRE_FORMAT[p[1]], "width": p[2], "height": p[3]}
                                       for p in want["profiles"]]
        assert got["default-profile"] == got["profiles"][want["default"]]
        assert got["metadata-enabled"] is False
        assert [o["json"] for o in got["options"]] == want["options"]
        for o, w in zip(got["options"], want["options"]):
            assert (o["name"], o["value"], o["min"], o["max"], o["step"], o["default"], o["description"]) == tuple(w)
    assert [o["json"] for o in desc["device-options"]] == SPEC["device-options"]
    (ext,) = desc["extrinsics"]
    assert (ext["from"], ext["to"]) == ("Depth", "Color")
    assert ext["rotation"] == [1, 0, 0, 0, 1, 0, 0, 0, 1]
    assert ext["translation"] == pytest.approx([0.015, 0.0, 0.0])
    assert desc["presets"] == []
    ev = events.next(types=("described",))
    assert ev["json"]["id"] == cam_id
    events.close()
    # Asked again (over HTTP this time), it is the kept one: no second subscription.
    status, _, again = describe(d, cam_id, via="tcp")
    assert status == 200 and again == desc
    assert subscriptions(d, cam["topic-root"]) == 1
    # A serial names the device too.
    assert describe(d, cam["serial"])[2] == desc
    server.quit()


def test_two_clients_at_once_share_one_fetch(free_domain, daemon, realdds_server):
    server, d, cam, cam_id = served_camera(2, free_domain, daemon, realdds_server)
    results = []
    threads = [threading.Thread(target=lambda: results.append(describe(d, cam_id))) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert [r[0] for r in results] == [200] * 4
    assert all(r[2] == results[0][2] for r in results)
    assert subscriptions(d, cam["topic-root"]) == 1
    server.quit()


def test_device_back_with_other_streams_is_described_anew(free_domain, daemon, realdds_server):
    server, d, cam, cam_id = served_camera(3, free_domain, daemon, realdds_server)
    assert len(describe(d, cam_id)[2]["streams"]) == 4
    server.command(cmd="remove", **{"topic-root": cam["topic-root"]})
    wait_for(lambda: d.device_ids() == [], what="the camera gone")
    depth_only = {"streams": [SPEC["streams"][1]]}
    server.command(cmd="add", info=cam, spec=depth_only)
    wait_for(lambda: d.device_ids() == [cam_id], what="the camera back")
    status, _, desc = describe(d, cam_id)
    assert status == 200 and [s["name"] for s in desc["streams"]] == ["Depth"], desc
    server.quit()


def test_servers_that_never_answer_or_never_finish(free_domain, daemon, cyclone_peer):
    d = daemon([free_domain], extra=["--describe-timeout", "3"])
    # A device announced by a writer with no server behind it: nobody answers.
    silent, broken = device_info(4), device_info(5)
    writer = cyclone_peer(free_domain, "writer")
    assert writer.next() == {"matched": True}
    announce(d, writer, free_domain, silent, broken)

    # A made-up server: a header of 2 streams, one stream, interleaved noise, garbage.
    notifier = cyclone_peer(free_domain, "writer", topic=broken["topic-root"] + "/notification")
    t = time.monotonic()
    status, headers, body = describe(d, dds_id(free_domain, silent))
    took = time.monotonic() - t
    assert status == 504 and "no complete description" in body["error"], body
    assert 2.5 <= took <= 3 + 2, took
    # The notifier matched the daemon's reader once the request subscribed.
    result = {}
    thread = threading.Thread(target=lambda: result.update(r=describe(d, dds_id(free_domain, broken))))
    thread.start()
    assert notifier.next() == {"matched": True}

    def rejected():
        return d.get_json("/v1/domains")["domains"][0]["rejected"]

    # Samples a just-matched writer sends before the daemon's Cyclone knows it are
    # lost for good (the late-joiner race): send garbage until one is counted.
    def heard():
        notifier.send(raw="7b6e6f74", format=0)  # "{not": not JSON
        return wait_for(lambda: rejected().get("notification-not-json"), timeout=0.5, fail=False)
    wait_for(heard, timeout=20, interval=0, what="the made-up server heard")
    not_json = rejected()["notification-not-json"]
    notifier.send(json={"id": "device-header", "n-streams": 2, "extrinsics": []})
    notifier.send(json={"id": "set-option", "option-name": "Exposure", "value": 1})  # another kind: ignored
    notifier.send(json={"id": "stream-header", "name": "Depth", "type": "depth", "sensor-name": "Stereo Module",
                        "profiles": [[30, "16UC1", 848, 480]], "default-profile-index": 0,
                        "metadata-enabled": False})
    notifier.send(json={"id": "stream-options", "stream-name": "Depth", "options": []})
    notifier.send(json={"id": "stream-options", "stream-name": "Nope", "options": []})  # unknown stream
    thread.join(30)
    status, _, body = result["r"]
    assert status == 504, body
    counts = rejected()
    assert counts["notification-not-json"] == not_json and counts.get("notification-unknown-stream") == 1, counts
    assert d.healthy()


def test_device_leaving_mid_fetch(free_domain, daemon, cyclone_peer):
    d = daemon([free_domain], extra=["--describe-timeout", "20"])
    cam = device_info(6)
    writer = cyclone_peer(free_domain, "writer")
    assert writer.next() == {"matched": True}
    announce(d, writer, free_domain, cam)
    result = {}
    thread = threading.Thread(target=lambda: result.update(r=describe(d, dds_id(free_domain, cam))))
    thread.start()
    wait_for(lambda: subscriptions(d, cam["topic-root"]) == 1, what="the fetch under way")
    t = time.monotonic()
    writer.close()  # its writer goes: the device leaves the table
    thread.join(30)
    status, _, body = result["r"]
    assert status == 404 and "left" in body["error"], body
    assert time.monotonic() - t < 10, "answered when the device left, not at the timeout"


def test_usb_and_recovery_devices_are_not_described(free_domain, daemon, realdds_server):
    rec = device_info(7, recovery=True)
    realdds_server(free_domain, [rec])
    d = daemon([free_domain])
    wait_for(lambda: d.device_ids() == [dds_id(free_domain, rec)], what="the camera in recovery")
    status, _, body = describe(d, dds_id(free_domain, rec))
    assert status == 409 and "recovery" in body["error"], body
    status, _, body = describe(d, "no-such-device")
    assert status == 404 and body["status"] == 404


def test_described_eagerly_when_configured(free_domain, daemon, realdds_server):
    server, d, cam, cam_id = served_camera(8, free_domain, daemon, realdds_server,
                                           extra=["--describe-eagerly", str(free_domain)])
    # Described without anyone asking; asking then answers from what is kept.
    wait_for(lambda: f"described {cam['topic-root']}" in d.log(), what="the camera described by itself")
    status, _, desc = describe(d, cam_id)
    assert status == 200 and len(desc["streams"]) == 4
    assert subscriptions(d, cam["topic-root"]) == 1
    server.quit()


def test_a_camera_whose_set_never_completes_is_not_ready(free_domain, daemon, cyclone_peer, realdds_server):
    """Found but never ready: with describe-eagerly, a camera whose server sends no
    notification, or stops after one stream of two, is `ready: false` with the
    stage its set reached once librealsense's 5 s wait is over, is asked again with
    back-off, and `doctor ID` names it; a real realdds server's camera is ready."""
    d = daemon([free_domain], extra=["--describe-eagerly", "all", "--describe-timeout", "8"])
    silent, stalled = device_info(8), device_info(9)
    writer = cyclone_peer(free_domain, "writer")
    assert writer.next() == {"matched": True}
    notifier = cyclone_peer(free_domain, "writer", topic=stalled["topic-root"] + "/notification")
    announce(d, writer, free_domain, silent, stalled)
    listed = time.monotonic()
    assert notifier.next() == {"matched": True}  # the daemon's eager fetch subscribed

    def rejected():
        return d.get_json("/v1/domains")["domains"][0]["rejected"]

    def heard():  # past the late-joiner race (see above)
        notifier.send(raw="7b6e6f74", format=0)
        return wait_for(lambda: rejected().get("notification-not-json"), timeout=0.5, fail=False)
    wait_for(heard, timeout=4, interval=0, what="the made-up server heard")
    notifier.send(json={"id": "device-header", "n-streams": 2, "extrinsics": []})
    notifier.send(json={"id": "stream-header", "name": "Depth", "type": "depth", "sensor-name": "Stereo Module",
                        "profiles": [[30, "16UC1", 848, 480]], "default-profile-index": 0,
                        "metadata-enabled": False})
    notifier.send(json={"id": "stream-options", "stream-name": "Depth", "options": []})

    def doc(info):
        return d.get_json(f"/v1/devices/{dds_id(free_domain, info)}")
    wait_for(lambda: doc(silent).get("ready") is False, timeout=15, what="the silent camera not ready")
    verdict = time.monotonic() - listed
    print(f"\nnot ready {verdict:.2f} s after the camera was listed (librealsense waits 5 s)")
    assert verdict >= 3.0, verdict  # not long before librealsense would have given up (5 s from the fetch)
    assert doc(silent)["ready-stage"] == "no device-header"
    wait_for(lambda: doc(stalled).get("ready-stage") == "stream 1 of 2", timeout=15, what="the stalled one's stage")
    assert doc(stalled)["ready"] is False
    status, body = d.request(f"/v1/devices/{dds_id(free_domain, stalled)}")[0:3:2]
    check = spec()["paths"]["/v1/devices/{id}"]["get"]["responses"]["200"]["content"]["application/json"]["schema"]
    OAS30Validator({**check, "components": spec()["components"]}).validate(json.loads(body))

    # Asked again after the fetch timed out (8 s) and the first back-off (5 s).
    wait_for(lambda: subscriptions(d, silent["topic-root"]) >= 2, timeout=25, what="the silent camera asked again")

    cli = os.path.join(os.environ["RSD_BUILD_DIR"], "client", "rs-discover")
    r = subprocess.run([cli, "--endpoint", "unix:" + d.socket, "doctor", "--json", "--listen", "0", stalled["serial"]],
                       capture_output=True, text=True, timeout=60)
    [ready] = [f for f in json.loads(r.stdout)["findings"] if f["topic"] == "ready"]
    assert ready["verdict"] == "warn" and "stopped at stream 1 of 2" in ready["text"], ready
    assert r.returncode == 1

    # A real server's camera: ready, with no stage.
    real = device_info(10)
    realdds_server(free_domain, []).command(cmd="add", info=real, spec=SPEC)
    wait_for(lambda: dds_id(free_domain, real) in d.device_ids() and doc(real).get("ready") is True, timeout=20,
             what="the real camera ready")
    assert "ready-stage" not in doc(real)
    assert d.healthy()


def test_doctor_asks_a_camera_never_described(free_domain, daemon, cyclone_peer):
    """By default (describe-eagerly off) no one has asked a camera for its set yet:
    `doctor ID` asks, as librealsense would open it, and names one that never
    completes, with its stage."""
    d = daemon([free_domain])
    silent = device_info(11)
    writer = cyclone_peer(free_domain, "writer")
    assert writer.next() == {"matched": True}
    announce(d, writer, free_domain, silent)
    cam_id = dds_id(free_domain, silent)
    assert "ready" not in d.get_json(f"/v1/devices/{cam_id}")  # not known until asked
    cli = os.path.join(os.environ["RSD_BUILD_DIR"], "client", "rs-discover")
    asked = time.monotonic()
    r = subprocess.run([cli, "--endpoint", "unix:" + d.socket, "doctor", "--json", "--listen", "0", silent["serial"]],
                       capture_output=True, text=True, timeout=60)
    print(f"\ndoctor ID on a camera never described: {time.monotonic() - asked:.2f} s")
    [ready] = [f for f in json.loads(r.stdout)["findings"] if f["topic"] == "ready"]
    assert ready["verdict"] == "warn" and "stopped at no device-header" in ready["text"], ready
    assert r.returncode == 1
    doc = d.get_json(f"/v1/devices/{cam_id}")
    assert doc["ready"] is False and doc["ready-stage"] == "no device-header", doc
