"""/v1/participants against real peers: a realdds server (pyrealsense2, Fast DDS)
and a PyPI cyclonedds 11 peer beside the daemon, listed with their vendor,
addresses, lease and what they announce; a peer that leaves and a server that is
killed both go, the killed one once its lease runs out. Every answer is checked
against the spec."""
import json
import os
import signal
import sys
import time

from conftest import device_info, wait_for

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "api"))
from api_util import validate_response  # noqa: E402  (the spec checks live with the API tests)


def participants(d, query=""):
    body = d.get_json("/v1/participants" + query)
    validate_response("/v1/participants", 200, body)
    return body["participants"]


def by_name(d, name, query=""):
    return next((p for p in participants(d, query) if p["name"] == name), None)


def test_realdds_server_and_cyclone_peer_are_listed_and_then_gone(free_domain, daemon, realdds_server,
                                                                        cyclone_peer):
    camera = device_info(1)
    server = realdds_server(free_domain, [camera], name="camera-server")
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 1, what="the realdds camera")
    peer = cyclone_peer(free_domain, "reader")
    assert peer.next() == {"reading": True}

    wait_for(lambda: by_name(d, "camera-server") is not None, what="the realdds server listed")
    realdds = by_name(d, "camera-server")
    assert realdds["domain"] == free_domain and realdds["state"] == "alive"
    assert realdds["vendor"] == "fast-dds" and realdds["vendor-id"] == "01.0f"
    assert realdds["lease-seconds"] == 3.0  # what realdds announces (realdds-wire.md)
    assert realdds["devices"] == 1 and realdds["device-info-writers"] >= 1
    assert realdds["never-announced"] is False
    assert realdds["addresses"] and not any(a.startswith("239.") for a in realdds["addresses"])
    assert "host" not in realdds  # Fast DDS does not say

    # The Cyclone 11 peer says where it runs; it announces no camera.
    def cyclone_listed():
        return [p for p in participants(d) if p["vendor"] == "cyclone-dds" and p.get("pid") == peer.proc.pid]
    wait_for(cyclone_listed, what="the Cyclone 11 peer listed with its pid")
    other = cyclone_listed()[0]
    assert other["process"].startswith("python") and other["host"] == os.uname().nodename
    assert other["lease-seconds"] == 10.0 and other["devices"] == 0 and other["device-info-writers"] == 0
    # The daemon's own participant is not among them.
    own = {x["participant-guid"] for x in d.get_json("/v1/domains")["domains"]}
    assert not own & {p["guid"] for p in participants(d)}

    # A peer that closes says goodbye; a server killed says nothing and is gone
    # once its 3 s lease runs out.
    peer.close()
    wait_for(lambda: [p["state"] for p in participants(d) if p["guid"] == other["guid"]] == ["gone"],
             what="the Cyclone peer gone")
    t0 = time.monotonic()
    server.proc.send_signal(signal.SIGKILL)
    server.proc.wait()
    wait_for(lambda: [p["state"] for p in participants(d) if p["guid"] == realdds["guid"]] == ["gone"],
             timeout=10, what="the killed server gone")
    assert time.monotonic() - t0 < 3.0 + 2.0
    gone = participants(d, "?state=GONE")
    assert [p["guid"] for p in gone] == [realdds["guid"], other["guid"]]  # latest first
    assert gone[0]["first-seen"] <= gone[0]["last-seen"] and gone[0]["devices"] == 0
    assert participants(d, "?state=alive") == []
    assert participants(d, f"?domain={(free_domain + 1) % 233}") == []


def test_bad_queries_are_400s(free_domain, daemon):
    d = daemon([free_domain])
    for query in ("?state=sleeping", "?domain=300", "?stat=alive"):
        status, _, body = d.request("/v1/participants" + query)
        assert status == 400, (query, body)
        validate_response("/v1/participants", 400, json.loads(body))
