"""The real ApiServer over a table fed through stdin (tests/api/api_harness):
what a DDS-fed table cannot produce on cue. Every test has its own socket and port."""
import json
import concurrent.futures
import os
import signal
import socket
import stat
import subprocess
import time

import pytest

from api_util import SSEStream, curl, get_json, metric, parse_metrics, raw, request, validate_response
from conftest import wait_for

HARNESS = os.environ.get("RSD_API_HARNESS") or os.path.join(
    os.environ.get("RSD_BUILD_DIR", ""), "tests", "api", "api_harness")


class Harness:
    def __init__(self, tmp_path, *args, sock="h.sock", http=True):
        self.socket = os.path.join(tmp_path, sock) if sock else None
        cmd = [HARNESS] + list(args)
        if self.socket:
            cmd += ["--socket", self.socket]
        if http:
            cmd += ["--http", "127.0.0.1:0"]
        self.stderr = open(os.path.join(tmp_path, f"harness-{time.monotonic_ns()}.log"), "w+")
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self.stderr,
                                     text=True)
        self.ready = self.proc.stdout.readline().strip()
        self.port = int(self.ready.split("=")[1]) if self.ready.startswith("ready") else None
        self.tcp = ("127.0.0.1", self.port) if self.port else None

    def command(self, line):
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        reply = self.proc.stdout.readline().strip()
        assert reply.startswith("ok "), reply
        return int(reply.split()[1])

    def upsert(self, device_id, doc):
        import json
        return self.command(f"upsert {device_id} {json.dumps(doc)}")

    def remove(self, device_id):
        return self.command(f"remove {device_id}")

    def stop(self):
        """Stops the server; returns how long ApiServer::stop() took, in ms."""
        if not self.ready.startswith("ready"):
            self.proc.wait(10)  # it refused to start and is on its way out
            return None
        if self.proc.poll() is not None:
            return None
        self.proc.stdin.write("stop\n")
        self.proc.stdin.flush()
        line = ""
        while line is not None and not line.startswith("stopped"):
            line = self.proc.stdout.readline()
            if not line:
                break
        self.proc.wait(10)
        assert self.proc.returncode == 0, self.log()
        return int(line.strip().split("=")[1]) if line.startswith("stopped") else None

    def log(self):
        self.stderr.seek(0)
        return self.stderr.read()


@pytest.fixture
def harness(tmp_path):
    assert os.path.exists(HARNESS), f"api_harness not built: {HARNESS}"
    started = []

    def start(*args, **kw):
        h = Harness(tmp_path, *args, **kw)
        started.append(h)
        return h

    yield start
    for h in started:
        if h.proc.poll() is None:
            h.stop()


def dev(n, domain=0, **extra):
    doc = {"name": "Intel RealSense D455", "serial": f"1236222707{n:02d}", "product-line": "D400",
           "product-id": "0B5C", "fw-version": "5.16.0.1", "topic-root": f"realsense/D455_1236222707{n:02d}",
           "recovery": False, "domain": domain, "source": "dds",
           "server": {"participant-guid": "01.02.03.04", "participant-name": "srv", "addresses": ["192.0.2.7"]}}
    doc.update(extra)
    return f"dds-{domain}-realsense.D455_1236222707{n:02d}", doc


def test_same_answers_on_unix_socket_and_tcp(harness):
    h = harness()
    assert h.port, h.ready
    h.upsert(*dev(1))
    for target in (h.socket, h.tcp):
        body = get_json(target, "/v1/devices")
        assert [d["id"] for d in body["devices"]] == ["dds-0-realsense.D455_123622270701"]
        validate_response("/v1/devices", 200, body)
        code, text = curl(target, "/v1/devices/dds-0-realsense.D455_123622270701")
        assert code == 200 and '"serial":"123622270701"' in text


def test_socket_is_0660_and_removed_on_stop(harness):
    h = harness()
    mode = os.stat(h.socket).st_mode
    assert stat.S_ISSOCK(mode) and stat.S_IMODE(mode) == 0o660, oct(mode)
    h.stop()
    assert not os.path.exists(h.socket)


def test_devices_ordered_and_filtered(harness):
    h = harness()
    h.upsert(*dev(3, domain=2))
    h.upsert(*dev(1, domain=1, **{"product-line": "D500"}))
    h.upsert("usb-0001", {"name": "Intel RealSense D435", "source": "usb", "product-line": "D400"})
    ids = lambda q: [d["id"] for d in get_json(h.socket, "/v1/devices" + q)["devices"]]
    assert ids("") == sorted(ids(""))
    assert len(ids("")) == 3
    assert ids("?domain=1") == ["dds-1-realsense.D455_123622270701"]
    assert ids("?domain=1&domain=2") == ["dds-1-realsense.D455_123622270701", "dds-2-realsense.D455_123622270703"]
    assert ids("?product-line=d400") == ["dds-2-realsense.D455_123622270703", "usb-0001"]
    assert ids("?source=usb") == ["usb-0001"]
    assert ids("?source=dds&domain=2") == ["dds-2-realsense.D455_123622270703"]
    assert ids("?domain=7") == []
    # One camera seen over DDS and USB is one entry with "sources": both filters find it.
    h.upsert("usb-0005", {"name": "Intel RealSense D455", "source": "usb", "serial": "123622270705"})
    h.upsert(*dev(5, domain=1))
    merged = [d for d in get_json(h.socket, "/v1/devices")["devices"] if d.get("serial") == "123622270705"]
    assert len(merged) == 1 and sorted(merged[0]["sources"]) == ["dds", "usb"], merged
    assert merged[0]["id"] in ids("?source=usb") and merged[0]["id"] in ids("?source=dds")


@pytest.mark.parametrize("query", ["?domain=-1", "?domain=233", "?domain=x", "?domain=", "?source=eth",
                                   "?product-line=", "?domian=1", "?since=1"])
def test_bad_filters_are_400(harness, query):
    h = harness(http=False)
    status, headers, body = request(h.socket, "/v1/devices" + query)
    assert status == 400, body
    import json
    err = json.loads(body)
    assert err["status"] == 400 and err["error"]
    validate_response("/v1/devices", 400, err)


# The 404 of a camera key, after "no device 'KEY' ": where the keys are.
NO_DEVICE = "(no camera listed has it as its id, serial or topic-root; GET /v1/devices lists them)"


def test_device_404_and_unknown_paths(harness):
    import json
    h = harness(http=False)
    status, _, body = request(h.socket, "/v1/devices/dds-0-nope")
    assert status == 404
    assert json.loads(body) == {"error": f"no device 'dds-0-nope' {NO_DEVICE}", "status": 404,
                                "complete": True}
    validate_response("/v1/devices/{id}", 404, json.loads(body))
    # "/" is the page and /openapi.yaml the spec (test_web_page.py); every other unknown path a JSON 404.
    for path in ("/index.html", "/v1", "/v1/devices/", "/v1/devices/a/b", "/v2/devices", "/healthz/x", "/metricsx"):
        status, headers, body = request(h.socket, path)
        assert status == 404, path
        assert headers["content-type"].startswith("application/json")
        assert json.loads(body)["status"] == 404


@pytest.mark.parametrize("method", ["POST", "PUT", "DELETE", "PATCH", "OPTIONS"])
def test_wrong_methods_are_405_with_allow(harness, method):
    import json
    h = harness()
    for target in (h.socket, h.tcp):
        for path in ("/v1/devices", "/v1/devices/x", "/v1/events", "/v1/domains", "/healthz", "/metrics"):
            for body in (None, b'{"a": 1}'):
                status, headers, text = request(target, path, method=method, body=body)
                assert status == 405, (method, path, text)
                assert headers["allow"] == "GET, HEAD"
                assert json.loads(text)["status"] == 405
        status, _, _ = request(target, "/nope", method=method)
        assert status == 404


def test_head_has_no_body(harness):
    h = harness(http=False)
    status, headers, body = request(h.socket, "/v1/devices", method="HEAD")
    assert status == 200 and body == b""


def test_garbage_never_hurts(harness):
    h = harness()
    junk = [
        b"\x00\xff\xfe garbage\r\n\r\n",
        b"GET\r\n\r\n",
        b"GET / HTTP/9.9\r\n\r\n",
        b"BREW /v1/devices HTTP/1.1\r\n\r\n",
        b"GET /" + b"a" * 20000 + b" HTTP/1.1\r\n\r\n",
        b"GET /v1/devices HTTP/1.1\r\n" + b"X-Big: " + b"b" * 70000 + b"\r\n\r\n",
        b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nContent-Length: -5\r\n\r\n",
        b"POST /v1/devices HTTP/1.1\r\nHost: localhost\r\nContent-Length: 99999999999\r\n\r\nabc",
        b"POST /v1/devices HTTP/1.1\r\nHost: localhost\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n",
        b"GET /v1/devices/%ff%fe%00 HTTP/1.1\r\nHost: localhost\r\n\r\n",
        b"GET /v1/devices?domain=%00 HTTP/1.1\r\nHost: localhost\r\n\r\n",
        b"GET /v1/events HTTP/1.1\r\nLast-Event-ID: \xff\xfe\r\n\r\n",
        b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\n",  # never finished
        bytes(range(256)) * 8,
    ]
    for target in (h.socket, h.tcp):
        for data in junk:
            raw(target, data, timeout=1.0)
            # Whatever the answer was, the server is still up.
            assert get_json(target, "/healthz")["status"] == "ok"
    # A connection that says nothing holds no one up.
    with socket.create_connection(h.tcp) as idle:
        assert get_json(h.tcp, "/healthz")["status"] == "ok"
    # A client that shuts its sending side after the request still gets the answer.
    out = raw(h.tcp, b"GET /v1/devices/%ff HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n")
    assert b" 404 " in out.split(b"\r\n")[0], out[:200]
    assert h.proc.poll() is None


def test_healthz_and_domains(harness):
    import json
    h = harness(http=False)
    health = get_json(h.socket, "/healthz")
    assert health["status"] == "ok" and health["version"] == "0.0.0-harness" and health["devices"] == 0
    validate_response("/healthz", 200, health)
    h.command('domains ' + json.dumps([{"domain": 3, "state": "running", "participant-guid": "01.aa",
                                        "accepted": 5, "rejected": {"not-json": 2}},
                                       {"domain": 1, "state": "failed"}]))
    h.upsert(*dev(1, domain=3))
    body = get_json(h.socket, "/v1/domains")
    validate_response("/v1/domains", 200, body)
    assert [d["domain"] for d in body["domains"]] == [1, 3]
    d3 = body["domains"][1]
    assert d3["devices"] == 1 and d3["accepted"] == 5 and d3["rejected"] == {"not-json": 2}
    assert body["domains"][0]["devices"] == 0


def test_answers_say_whether_the_table_is_complete(harness):
    """Until every domain's first discovery is over, every answer that counts devices says
    "complete": false (a missing camera may not have been heard yet); then true."""
    import json
    h = harness(http=False)
    h.upsert(*dev(1, domain=3))
    h.command('domains ' + json.dumps([{"domain": 3, "complete": True}, {"domain": 4, "complete": False}]))

    def answers():
        listing = get_json(h.socket, "/v1/devices")
        validate_response("/v1/devices", 200, listing)
        health = get_json(h.socket, "/healthz")
        validate_response("/healthz", 200, health)
        domains = get_json(h.socket, "/v1/domains")
        validate_response("/v1/domains", 200, domains)
        status, _, body = request(h.socket, "/v1/devices/dds-4-later")
        missing = json.loads(body)
        assert status == 404
        validate_response("/v1/devices/{id}", 404, missing)
        return listing, health, domains, missing

    listing, health, domains, missing = answers()
    assert listing["complete"] is False and [d["id"] for d in listing["devices"]] == [dev(1, domain=3)[0]]
    assert health["complete"] is False and health["status"] == "ok"  # healthy; the count is not final yet
    assert domains["complete"] is False
    assert {d["domain"]: d["complete"] for d in domains["domains"]} == {3: True, 4: False}
    assert missing["complete"] is False and "not complete" in missing["error"]
    assert metric(parse_metrics(get_text(h.socket, "/metrics")), "rsd_table_complete") == 0

    h.command('domains ' + json.dumps([{"domain": 3, "complete": True}, {"domain": 4, "complete": True}]))
    listing, health, domains, missing = answers()
    assert listing["complete"] is True and health["complete"] is True and domains["complete"] is True
    assert missing == {"error": f"no device 'dds-4-later' {NO_DEVICE}",
                       "status": 404, "complete": True}
    assert metric(parse_metrics(get_text(h.socket, "/metrics")), "rsd_table_complete") == 1


def get_text(target, path):
    status, _, body = request(target, path)
    assert status == 200, (path, status)
    return body.decode()


def test_metrics(harness):
    import json
    h = harness(http=False)
    h.command('domains ' + json.dumps([{"domain": 4, "accepted": 9, "rejected": {"bad-cbor": 1}}]))
    h.upsert(*dev(1, domain=4))
    request(h.socket, "/nope")
    status, headers, body = request(h.socket, "/metrics")
    assert status == 200
    assert headers["content-type"].startswith("text/plain; version=0.0.4")
    parse_metrics(body.decode())
    # Requests are counted once their answer is out, so the client may be faster.
    m = wait_for(lambda: (lambda x: x if metric(x, "rsd_api_requests_total", status="404") else None)(
        parse_metrics(request(h.socket, "/metrics")[2].decode())), what="the 404 counted")
    assert metric(m, "rsd_domain_devices", domain="4") == 1
    assert metric(m, "rsd_messages_accepted_total", domain="4") == 9
    assert metric(m, "rsd_messages_rejected_total", domain="4", reason="bad-cbor") == 1
    assert metric(m, "rsd_api_requests_total", status="404") == 1
    assert metric(m, "rsd_events_sent_total") == 0
    s = SSEStream(h.socket, "/v1/events?since=0")
    assert s.next_event()["event"] == "added"
    # The event is counted once written, so the client may read it first.
    m = wait_for(lambda: (lambda x: x if metric(x, "rsd_event_streams") == 1
                          and metric(x, "rsd_events_sent_total") == 1 else None)(
        parse_metrics(request(h.socket, "/metrics")[2].decode())), what="stream and its event counted")
    assert metric(m, "rsd_api_requests_total", status="200") >= 1
    s.close()


def test_events_hello_then_live(harness):
    h = harness()
    gen0 = h.upsert(*dev(1))
    # Browsers ask for gzip; a compressed stream would hold events back in the compressor.
    s = SSEStream(h.tcp, headers={"Accept-Encoding": "gzip, br"})
    assert s.status == 200 and s.headers["content-type"].startswith("text/event-stream")
    assert s.headers["cache-control"] == "no-cache" and "content-encoding" not in s.headers
    hello = s.next_event()
    assert hello["event"] == "hello" and int(hello["id"]) == gen0 and hello["json"]["generation"] == gen0
    did, doc = dev(2)
    g_add = h.upsert(did, doc)
    g_chg = h.upsert(did, dict(doc, recovery=True))
    h.upsert(did, dict(doc, recovery=True))  # only last-seen moves: no event
    g_rm = h.remove(did)
    events = [s.next_event() for _ in range(3)]
    assert [(e["event"], int(e["id"])) for e in events] == [("added", g_add), ("changed", g_chg), ("removed", g_rm)]
    assert events[1]["json"]["recovery"] is True and events[2]["json"]["id"] == did
    for e in events:
        validate_response("/v1/devices/{id}", 200, e["json"])
    s.close()


def test_list_then_stream_since_generation(harness):
    h = harness(http=False)
    h.upsert(*dev(1))
    listing = get_json(h.socket, "/v1/devices")
    g = h.upsert(*dev(2))  # happens between the list and the stream
    s = SSEStream(h.socket, f"/v1/events?since={listing['generation']}")
    e = s.next_event()
    assert e["event"] == "added" and int(e["id"]) == g
    s.close()


def test_resume_with_last_event_id(harness):
    h = harness(http=False)
    s = SSEStream(h.socket)
    hello = s.next_event()
    g1 = h.upsert(*dev(1))
    assert int(s.next_event()["id"]) == g1
    s.close()
    missed = [h.upsert(*dev(2)), h.upsert(*dev(3)), h.remove(dev(1)[0])]
    s2 = SSEStream(h.socket, headers={"Last-Event-ID": str(g1)})
    got = [s2.next_event() for _ in range(3)]
    assert [int(e["id"]) for e in got] == missed
    assert [e["event"] for e in got] == ["added", "added", "removed"]
    live = h.upsert(*dev(4))
    assert int(s2.next_event()["id"]) == live
    s2.close()
    # Last-Event-ID wins over ?since; an id from "now" replays nothing.
    s3 = SSEStream(h.socket, f"/v1/events?since={hello['id']}", headers={"Last-Event-ID": str(live)})
    g5 = h.upsert(*dev(5))
    assert int(s3.next_event()["id"]) == g5
    s3.close()


def test_resync_when_too_far_behind(harness):
    h = harness("--log-capacity", "3", http=False)
    g1 = h.upsert(*dev(1))
    for n in range(2, 8):
        h.upsert(*dev(n))
    gen = h.upsert(*dev(8))
    s = SSEStream(h.socket, headers={"Last-Event-ID": str(g1)})
    e = s.next_event()
    assert e["event"] == "resync" and int(e["id"]) == gen and e["json"]["generation"] == gen
    g = h.upsert(*dev(9))
    assert int(s.next_event()["id"]) == g  # and then it carries on live
    s.close()
    for bad in ("banana", "99999999999999999999999", str(gen + 1000)):
        s = SSEStream(h.socket, headers={"Last-Event-ID": bad})
        assert s.next_event()["event"] == "resync", bad
        s.close()
    assert request(h.socket, "/v1/events?since=banana")[0] == 400


def test_events_filtered(harness):
    h = harness(http=False)
    s = SSEStream(h.socket, "/v1/events?domain=5")
    s.next_event()  # hello
    h.upsert(*dev(1, domain=4))
    g = h.upsert(*dev(2, domain=5))
    e = s.next_event()
    assert int(e["id"]) == g and e["json"]["domain"] == 5
    s.close()


def test_a_filtered_stream_sees_devices_leave_and_enter_its_filter(harness):
    # A watcher of one camera network (?address=): its server renumbered, the camera
    # is no longer on that network, and for this watcher it is gone (it would not
    # list it either); moved back, it is there again.
    h = harness(http=False)
    s = SSEStream(h.socket, "/v1/events?address=192.0.2.7")
    s.next_event()  # hello
    device_id, doc = dev(1, domain=5)
    h.upsert(device_id, doc)
    assert s.next_event()["event"] == "added"
    moved = dict(doc, server=dict(doc["server"], addresses=["198.51.100.7"]))
    g = h.upsert(device_id, moved)
    e = s.next_event()
    assert (e["event"], e["json"]["id"], int(e["id"])) == ("removed", device_id, g)
    h.upsert(device_id, dict(moved, name="Intel RealSense D455 (renamed)"))  # outside the filter: nothing
    g = h.upsert(device_id, doc)
    e = s.next_event()
    assert (e["event"], int(e["id"])) == ("added", g), e
    assert request(h.socket, "/v1/devices?address=192.0.2.7")[0] == 200
    s.close()


def test_keepalive_comments(harness):
    h = harness("--keepalive-ms", "200", http=False)
    s = SSEStream(h.socket)
    s.next_event()
    t0 = time.monotonic()
    comments = [s.next(timeout=3, comments=True) for _ in range(3)]
    assert all(c == {"comment": "keep-alive"} for c in comments), comments
    assert time.monotonic() - t0 < 2.0
    s.close()


def test_stream_limit_is_503_and_frees_up(harness):
    import json
    h = harness("--max-streams", "2", "--keepalive-ms", "300")
    a, b = SSEStream(h.socket), SSEStream(h.tcp)
    a.next_event(), b.next_event()
    c = SSEStream(h.socket)
    assert c.status == 503 and c.headers["retry-after"]
    err = json.loads(c.body)
    assert err["status"] == 503 and "too many" in err["error"]
    validate_response("/v1/events", 503, err)
    assert get_json(h.socket, "/healthz")["status"] == "ok"  # plain requests still served
    a.close()

    def reopened():
        s = SSEStream(h.tcp)
        if s.status == 200:
            return s
        s.close()
        return None
    # A closed client frees its slot once a write to it fails: the next keep-alive.
    d = wait_for(reopened, timeout=40, interval=0.5, what="a stream slot to free up")
    d.close()
    b.close()


def test_many_parallel_clients(harness):
    h = harness()
    for n in range(30):
        h.upsert(*dev(n))
    streams = [SSEStream(h.socket) for _ in range(8)]
    for s in streams:
        s.next_event()

    def hit(i):
        target = h.socket if i % 2 else h.tcp
        return len(get_json(target, "/v1/devices")["devices"])
    with concurrent.futures.ThreadPoolExecutor(16) as pool:
        assert set(pool.map(hit, range(400))) == {30}
    for s in streams:
        s.close()


def test_tcp_nodelay_keepalive_requests_are_fast(harness):
    import http.client
    h = harness()
    conn = http.client.HTTPConnection(*h.tcp, timeout=5)
    t0 = time.monotonic()
    for _ in range(100):
        conn.request("GET", "/healthz")
        r = conn.getresponse()
        r.read()
        assert r.status == 200
    elapsed = time.monotonic() - t0
    conn.close()
    # With Nagle on, each keep-alive round trip costs ~40 ms (4 s for 100).
    assert elapsed < 2.0, elapsed


def test_stop_is_prompt_with_open_streams_and_idle_connections(harness):
    h = harness()
    streams = [SSEStream(h.socket) for _ in range(4)] + [SSEStream(h.tcp) for _ in range(4)]
    for s in streams:
        s.next_event()
    idle = [socket.create_connection(h.tcp) for _ in range(3)]
    half = socket.create_connection(h.tcp)
    half.sendall(b"GET /v1/devices HTTP/1.1\r\nHost: localhost\r\n")  # a request never finished
    import http.client
    kept = http.client.HTTPConnection(*h.tcp, timeout=5)
    kept.request("GET", "/healthz")
    kept.getresponse().read()  # leaves an idle keep-alive connection behind
    ms = h.stop()
    assert ms is not None and ms < 500, ms
    for s in streams:
        assert s.next(timeout=2) is None  # every stream ended
    for c in idle + [half]:
        c.close()
    assert not os.path.exists(h.socket)


def test_stale_socket_replaced_live_socket_refused(harness, tmp_path):
    path = os.path.join(tmp_path, "h.sock")
    stale = socket.socket(socket.AF_UNIX)
    stale.bind(path)
    stale.close()  # what a crashed daemon leaves: a socket file nobody accepts on
    first = harness(http=False)
    assert first.ready.startswith("ready"), first.ready
    assert get_json(path, "/healthz")["status"] == "ok"
    second = harness(http=False)  # same path
    assert second.ready.startswith("error") and "already running" in second.ready, second.ready
    second.proc.wait(5)
    assert second.proc.returncode != 0
    assert os.path.exists(path) and get_json(path, "/healthz")["status"] == "ok"
    # A regular file at the path is not ours to delete.
    first.stop()
    with open(path, "w") as f:
        f.write("precious")
    third = harness(http=False)
    assert third.ready.startswith("error"), third.ready
    with open(path) as f:
        assert f.read() == "precious"


def test_port_in_use_is_a_clear_error(harness, tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        h = harness(sock="x.sock", http=False)
        h.stop()
        h2 = Harness(tmp_path, "--http", f"127.0.0.1:{port}", sock="y.sock", http=False)
        assert h2.ready.startswith("error") and "in use" in h2.ready, h2.ready
        h2.proc.wait(5)
        # The Unix socket it had already bound is not left behind.
        assert not os.path.exists(os.path.join(tmp_path, "y.sock"))


def test_killed_server_leaves_socket_next_start_replaces_it(harness):
    h = harness(http=False)
    h.proc.send_signal(signal.SIGKILL)
    h.proc.wait(5)
    # A SIGKILLed server leaves its socket file: the next start replaces it.
    assert os.path.exists(h.socket)
    h2 = harness(http=False)
    assert h2.ready.startswith("ready"), h2.ready


def test_device_list_has_an_etag_per_generation_and_answers_304(harness):
    """A poller that sends back the ETag gets a 304 until the table changes."""
    h = harness()
    h.upsert(*dev(1))
    for target in (h.socket, h.tcp):
        status, headers, body = request(target, "/v1/devices")
        assert status == 200
        etag = headers["etag"]
        assert etag == f'"{json.loads(body)["generation"]}"'
        status, headers, body = request(target, "/v1/devices", headers={"If-None-Match": etag})
        assert (status, body, headers["etag"]) == (304, b"", etag)
        # Filters share the generation; each filter's body is its own.
        status, _, body = request(target, "/v1/devices?domain=5")
        assert status == 200 and json.loads(body)["devices"] == []
    generation = h.upsert(*dev(2))
    status, headers, body = request(h.tcp, "/v1/devices", headers={"If-None-Match": etag})
    assert status == 200 and headers["etag"] == f'"{generation}"'
    assert [d["serial"] for d in json.loads(body)["devices"]] == ["123622270701", "123622270702"]
    # Before the first discovery ends the tag says so: a complete list never matches it.
    h.command('domains [{"domain": 0, "complete": false}]')
    _, headers, _ = request(h.tcp, "/v1/devices")
    assert headers["etag"] == f'"{generation}-partial"'
