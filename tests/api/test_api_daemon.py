"""The API of the real rs-discoveryd: curl over the Unix socket and TCP, error
bodies, health, metrics, the event stream, and responses checked against
proto/openapi.yaml, with real realdds servers (pyrealsense2) as the devices."""
import json
import os
import re
import signal
import socket
import subprocess
import time

from api_util import SSEStream, curl, get_json, metric, parse_metrics, request, spec, validate_response
from conftest import DAEMON, device_info, wait_for


def test_openapi_spec_is_valid():
    from openapi_spec_validator import validate
    validate(spec())


def test_empty_daemon_over_curl_unix_and_tcp(daemon, free_domain):
    d = daemon([free_domain])
    for target in (d.socket, ("127.0.0.1", d.port)):
        code, text = curl(target, "/v1/devices")
        assert code == 200
        body = json.loads(text)
        assert body["devices"] == [] and isinstance(body["generation"], int)
        validate_response("/v1/devices", 200, body)

        code, text = curl(target, "/healthz")
        health = json.loads(text)
        assert code == 200 and health["status"] == "ok" and health["devices"] == 0 and health["version"]
        validate_response("/healthz", 200, health)

        code, text = curl(target, "/v1/domains")
        domains = json.loads(text)
        validate_response("/v1/domains", 200, domains)
        assert [x["domain"] for x in domains["domains"]] == [free_domain]
        assert domains["domains"][0]["state"] == "running" and domains["domains"][0]["participant-guid"]


def test_error_bodies(daemon, free_domain):
    d = daemon([free_domain])
    for target in (d.socket, ("127.0.0.1", d.port)):
        code, text = curl(target, "/v1/devices/dds-0-realsense.nothing")
        assert code == 404
        err = json.loads(text)
        # "complete" tells whether the camera may still turn up (the daemon started moments ago).
        assert err["status"] == 404 and isinstance(err["complete"], bool)
        assert err["error"].startswith("no device 'dds-0-realsense.nothing' (no camera listed has it as its id, "
                                        "serial or topic-root; GET /v1/devices lists them)")
        # A serial no camera has: the same words (it is a key like any other).
        code, text = curl(target, "/v1/devices/999999")
        assert code == 404 and json.loads(text)["error"].startswith("no device '999999' (no camera listed"), text
        validate_response("/v1/devices/{id}", 404, err)

        code, text = curl(target, "/no/such/path")
        assert code == 404 and json.loads(text)["status"] == 404

        code, text = curl(target, "/v1/devices?domain=999")
        assert code == 400 and "domain" in json.loads(text)["error"]
        validate_response("/v1/devices", 400, json.loads(text))

        for method in ("POST", "PUT", "DELETE", "PATCH"):
            code, text = curl(target, "/v1/devices", "-X", method)
            assert code == 405, (method, text)
            validate_response("/v1/devices", 405, json.loads(text))
        status, headers, _ = request(target, "/v1/domains", method="DELETE")
        assert status == 405 and headers["allow"] == "GET, HEAD"


def test_every_documented_counter_is_there_from_the_start(daemon, free_domain):
    """An alert on rate() or increase() sees a counter only once it exists: each one
    the spec lists has its samples at 0 in the first scrape, before anything happened."""
    description = spec()["paths"]["/metrics"]["get"]["description"]
    documented = set(re.findall(r"\b((?:rsd|process)_[a-z_]+)", description))
    # One expected camera, never there: its rsd_expected_camera_present is 0 from the start
    # (with nothing expected the family is absent, as the USB ones are under --no-usb).
    d = daemon([free_domain], extra=["--expect", "front=000000000001"])
    _, _, body = request(d.socket, "/metrics")  # nothing happened but the fixture's readiness checks
    text = body.decode()
    types = dict(line.split()[2:4] for line in text.splitlines() if line.startswith("# TYPE "))
    samples = parse_metrics(text)
    counters = sorted(name for name in documented if types.get(name) == "counter")
    assert {"rsd_messages_rejected_total", "rsd_api_requests_total", "process_cpu_seconds_total"} <= set(counters)
    assert all(name in types for name in documented if not name.startswith("rsd_usb_")), \
        sorted(documented - set(types))  # --no-usb: no USB families
    for name in counters:
        values = [v for (n, _), v in samples.items() if n == name]
        assert values, f"{name}: no sample in a fresh daemon's /metrics"
    dom = str(free_domain)
    for reason in ("not-json", "too-large", "missing-name", "domain-device-limit", "refused-writer"):
        assert metric(samples, "rsd_messages_rejected_total", domain=dom, reason=reason) == 0, reason
    for status in ("404", "409", "503"):  # 200: the fixture asked until the daemon was ready
        assert metric(samples, "rsd_api_requests_total", status=status) == 0, status
    # One name for the per-domain count; the 0.1.0 name stays, said deprecated, for a release.
    assert metric(samples, "rsd_domain_devices", domain=dom) == 0
    assert metric(samples, "rsd_devices", domain=dom) == 0
    assert "# HELP rsd_devices Deprecated" in text


def test_metrics_parse(daemon, free_domain):
    d = daemon([free_domain])
    curl(d.socket, "/nope")
    status, headers, body = request(d.socket, "/metrics")
    assert status == 200 and headers["content-type"].startswith("text/plain; version=0.0.4")
    m = parse_metrics(body.decode())
    assert metric(m, "rsd_domain_devices", domain=str(free_domain)) == 0
    assert metric(m, "rsd_messages_accepted_total", domain=str(free_domain)) == 0
    assert metric(m, "rsd_events_sent_total") == 0
    assert metric(m, "rsd_domain_up", domain=str(free_domain), state="running") == 1
    # The process's own figures, under the names every Prometheus client library uses.
    assert 1e6 < metric(m, "process_resident_memory_bytes") < 1e9
    assert metric(m, "process_open_fds") >= 3
    assert time.time() - 600 < metric(m, "process_start_time_seconds") <= time.time() + 1  # started for this test
    assert metric(m, "process_cpu_seconds_total") >= 0
    wait_for(lambda: metric(parse_metrics(request(d.socket, "/metrics")[2].decode()),
                            "rsd_api_requests_total", status="404") == 1, what="the 404 counted")


def test_real_device_listed_validated_and_streamed(daemon, free_domain, realdds_server):
    d = daemon([free_domain])
    stream = SSEStream(d.socket)
    hello = stream.next_event()
    assert hello["event"] == "hello"

    info = device_info(1)
    server = realdds_server(free_domain, [info], name="api-test-server")
    added = stream.next_event(timeout=15)
    assert added["event"] == "added" and int(added["id"]) > int(hello["id"])
    dev = added["json"]
    assert dev["serial"] == info["serial"] and dev["topic-root"] == info["topic-root"]
    assert dev["domain"] == free_domain and dev["source"] == "dds"
    assert dev["server"]["participant-name"] == "api-test-server"

    listing = get_json(d.socket, "/v1/devices")
    validate_response("/v1/devices", 200, listing)
    assert [x["id"] for x in listing["devices"]] == [dev["id"]]
    for key, value in info.items():
        assert listing["devices"][0][key] == value, key  # device-info kept verbatim
    one = get_json(("127.0.0.1", d.port), "/v1/devices/" + dev["id"])
    validate_response("/v1/devices/{id}", 200, one)
    assert one["id"] == dev["id"]

    ids = lambda q: [x["id"] for x in get_json(d.socket, "/v1/devices" + q)["devices"]]
    assert ids(f"?domain={free_domain}") == [dev["id"]]
    assert ids(f"?domain={(free_domain % 232) + 1}") == []
    assert ids("?product-line=D400&source=dds") == [dev["id"]]
    assert ids("?source=usb") == []

    domains = get_json(d.socket, "/v1/domains")
    validate_response("/v1/domains", 200, domains)
    assert domains["domains"][0]["devices"] == 1 and domains["domains"][0]["accepted"] >= 1
    health = get_json(d.socket, "/healthz")
    assert health["devices"] == 1
    # The event is counted once written, so the stream's reader may have had it first.
    m = wait_for(lambda: (lambda x: x if metric(x, "rsd_events_sent_total") >= 1 else None)(
        parse_metrics(request(d.socket, "/metrics")[2].decode())), what="the added event counted")
    assert metric(m, "rsd_domain_devices", domain=str(free_domain)) == 1

    # Miss the removal while disconnected, then resume from the last id seen.
    stream.close()
    server.command(cmd="disconnect", **{"topic-root": info["topic-root"]})
    wait_for(lambda: get_json(d.socket, "/v1/devices")["devices"] == [], timeout=10, what="device removed")
    resumed = SSEStream(("127.0.0.1", d.port), headers={"Last-Event-ID": added["id"]})
    removed = resumed.next_event()
    assert removed["event"] == "removed" and removed["json"]["id"] == dev["id"]
    assert int(removed["id"]) > int(added["id"])
    resumed.close()


def test_fields_sends_only_the_keys_asked_for(daemon, free_domain, realdds_server):
    """?fields= (what `rs-discover list`'s table asks for): each device with those keys
    and its id, the rest of the list as without it; a malformed list is a 400."""
    d = daemon([free_domain])
    realdds_server(free_domain, [device_info(1), device_info(2)], name="fields-server")
    wait_for(lambda: (lambda x: len(x["devices"]) == 2 and x["complete"])(get_json(d.socket, "/v1/devices")),
             timeout=15, what="2 devices listed, the table complete")
    whole = get_json(d.socket, "/v1/devices")
    by_id = {x["id"]: x for x in whole["devices"]}

    some = get_json(d.socket, "/v1/devices?fields=serial,server.addresses")
    assert some["generation"] == whole["generation"] and some["complete"] is True
    assert [x["id"] for x in some["devices"]] == [x["id"] for x in whole["devices"]]
    for x in some["devices"]:
        full = by_id[x["id"]]
        assert x == {"id": full["id"], "serial": full["serial"], "server": {"addresses": full["server"]["addresses"]}}
    # Repeated, the lists join; a whole object and a key inside it: the whole object.
    joined = get_json(d.socket, "/v1/devices?fields=name&fields=server,server.addresses")
    assert [set(x) for x in joined["devices"]] == [{"id", "name", "server"}] * 2
    assert [x["server"] for x in joined["devices"]] == [x["server"] for x in whole["devices"]]
    # With a filter; a key no device has is absent, not an error.
    one = get_json(d.socket, f"/v1/devices?serial={device_info(2)['serial']}&fields=no-such-key")
    assert one["devices"] == [{"id": next(i for i, x in by_id.items() if x["serial"] == device_info(2)["serial"])}]
    # The whole list is still whole after the projected ones (the daemon caches each).
    assert get_json(d.socket, "/v1/devices") == whole

    for bad in ["", "a,,b", ",name", "name,", "server..addresses", ".name", "na%20me", "n%C3%A4me",
                ",".join(f"k{i}" for i in range(33))]:
        status, _, body = request(d.socket, "/v1/devices?fields=" + bad)
        assert status == 400, bad
        validate_response("/v1/devices", 400, json.loads(body))
        assert "fields" in json.loads(body)["error"], body


def test_events_keepalive(daemon, free_domain):
    d = daemon([free_domain])
    stream = SSEStream(d.socket)
    stream.next_event()
    # The daemon's default interval is 15 s (the harness test covers short ones).
    comment = stream.next(timeout=20, comments=True)
    assert comment == {"comment": "keep-alive"}
    stream.close()


def test_sigterm_ends_streams_and_removes_socket(daemon, free_domain):
    d = daemon([free_domain])
    streams = [SSEStream(d.socket), SSEStream(("127.0.0.1", d.port))]
    for s in streams:
        s.next_event()
    idle = socket.create_connection(("127.0.0.1", d.port))
    t0 = time.monotonic()
    d.signal(signal.SIGTERM)
    d.proc.wait(5)
    elapsed = time.monotonic() - t0
    assert d.proc.returncode == 0, d.log()[-2000:]
    assert elapsed < 1.0, elapsed
    for s in streams:
        assert s.next(timeout=2) is None
    idle.close()
    assert not os.path.exists(d.socket)


def test_stale_socket_replaced_live_daemon_refused(daemon, free_domain, tmp_path):
    path = os.path.join(tmp_path, "shared.sock")
    stale = socket.socket(socket.AF_UNIX)
    stale.bind(path)
    stale.close()  # what a SIGKILLed daemon leaves behind
    first = daemon([free_domain], extra=["--socket", path], wait=False)
    first.socket = path
    first.wait_ready()
    assert os.stat(path).st_mode & 0o777 == 0o660

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    second = subprocess.run([DAEMON, "--domain", str(free_domain), "--socket", path, "--http", f"127.0.0.1:{port}",
                             "--no-usb"], capture_output=True, text=True, timeout=10)
    assert second.returncode != 0
    assert "already running" in second.stderr, second.stderr
    # The first daemon keeps its socket and keeps serving.
    assert get_json(path, "/healthz")["status"] == "ok"


def test_removal_reasons_are_spelled_once(daemon, free_domain):
    """RemovalReason and HostVerdict as the spec has them are the labels the daemon's
    model gives /metrics from the start, and the Python client's REMOVAL_REASONS."""
    import sys
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                                    "client", "python", "src"))
    from rsdiscovery._history import REMOVAL_REASONS

    schemas = spec()["components"]["schemas"]
    reasons, verdicts = schemas["RemovalReason"]["enum"], schemas["HostVerdict"]["enum"]
    d = daemon([free_domain])
    samples = parse_metrics(request(d.socket, "/metrics")[2].decode())
    labels = {}
    for (name, pairs), _ in samples.items():
        for label, value in pairs:
            labels.setdefault((name, label), set()).add(value)
    assert labels[("rsd_device_removals_total", "reason")] == set(reasons)
    assert labels[("rsd_lease_expired_hosts_total", "verdict")] == set(verdicts)
    assert tuple(reasons) == REMOVAL_REASONS  # in the spec's order
