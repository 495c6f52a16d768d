"""The rsdiscovery package against the real daemon and real realdds servers."""
import json
import os
import time

import pytest
from conftest import DOMAIN, info, wait_for

import rsdiscovery


def test_installed_not_from_the_tree():
    assert "site-packages" in rsdiscovery.__file__, rsdiscovery.__file__


def test_endpoints(tmp_path, monkeypatch):
    assert rsdiscovery.Endpoint.parse("unix:///run/x.sock").path == "/run/x.sock"
    assert str(rsdiscovery.Endpoint.parse("http://127.0.0.1:8035")) == "http://127.0.0.1:8035"
    with pytest.raises(ValueError):
        rsdiscovery.Endpoint.parse("ftp://x")
    monkeypatch.delenv("RS_DISCOVERY_ENDPOINT", raising=False)
    monkeypatch.setenv("RUNTIME_DIRECTORY", str(tmp_path))
    assert rsdiscovery.Endpoint.from_environment().path == f"{tmp_path}/api.sock"
    with pytest.raises(rsdiscovery.DaemonNotRunning, match=f"no socket at {tmp_path}/api.sock"):
        rsdiscovery.list_devices()


def test_list_get_wait_domains_health(daemon_factory, server_factory):
    d = daemon_factory()
    ep = "unix:" + d.socket
    t0 = time.monotonic()
    with pytest.raises(TimeoutError, match="0 of 1"):
        rsdiscovery.wait_for(timeout=0.3, endpoint=ep)
    assert time.monotonic() - t0 < 3
    server_factory([info(1), info(2)])
    dev = rsdiscovery.wait_for(lambda x: x.serial == "9876543202", timeout=20, endpoint=ep)
    assert dev is not None and dev.domain == DOMAIN
    assert rsdiscovery.wait_for(timeout=20, count=2, endpoint=ep) is not None
    devices = rsdiscovery.list_devices(endpoint=ep)
    assert sorted(x.serial for x in devices) == ["9876543201", "9876543202"]
    assert rsdiscovery.list_devices(domain=DOMAIN + 1, endpoint=ep) == []
    assert len(rsdiscovery.list_devices(product_line="D400", source="dds", endpoint=d.url)) == 2
    got = rsdiscovery.get_device(dev.id, endpoint=ep)
    assert got.topic_root == "realsense/D455_9876543202" and got.server and got.server.addresses
    with pytest.raises(rsdiscovery.NotFound):
        rsdiscovery.get_device("nope", endpoint=ep)
    assert rsdiscovery.domains(endpoint=ep)[0].domain == DOMAIN
    assert rsdiscovery.health(endpoint=ep).status == "ok"


def test_watch_resumes_across_a_daemon_restart(daemon_factory, server_factory):
    d = daemon_factory()
    ep = "unix:" + d.socket
    srv = server_factory([info(11)])
    wait_for(lambda: rsdiscovery.list_devices(endpoint=ep), what="first device")
    client = rsdiscovery.Client(ep)
    view = {}
    seen = []

    def fold(e):
        seen.append(e)
        if e.type == "removed":
            view.pop(e.device.id, None)
        else:
            view[e.device.id] = e.device

    with client.watcher(initial=True) as w:
        e = w.next(10)
        assert e.type == "added" and e.synthetic
        fold(e)
        srv.command(cmd="add", info=info(12))
        e = w.next(20)
        assert e.type == "added" and not e.synthetic and e.id > 0
        fold(e)
        d.stop()
        srv.command(cmd="remove", **{"topic-root": "realsense/D455_9876543211"})
        srv.command(cmd="add", info=info(13))
        d2 = daemon_factory()
        want = sorted(f"dds-{DOMAIN}-realsense.D455_98765432{n}" for n in (12, 13))
        wait_for(lambda: sorted(x.id for x in rsdiscovery.list_devices(endpoint=ep)) == want,
                 what="the restarted daemon's view")

        def caught_up():
            e = w.next(0.2)
            if e:
                fold(e)
            return sorted(view) == want

        wait_for(caught_up, what="the watch's view to match")
        assert any(e.type == "removed" and e.device.serial == "9876543211" for e in seen)
        assert w.last_event_id and w.last_event_id > seen[1].id
        d2.stop()

    # The generator form ends cleanly when closed.
    d3 = daemon_factory()
    gen = rsdiscovery.watch(initial=True, endpoint="unix:" + d3.socket)
    first = next(gen)
    assert first.type == "added"
    gen.close()
    d3.stop()


def test_daemon_gone_errors(tmp_path):
    with pytest.raises(rsdiscovery.DaemonNotRunning, match="no socket at"):
        rsdiscovery.list_devices(endpoint=f"unix:{tmp_path}/none.sock")
    with pytest.raises(rsdiscovery.DaemonNotRunning):
        rsdiscovery.watch(endpoint=f"unix:{tmp_path}/none.sock")
    assert issubclass(rsdiscovery.VersionMismatch, rsdiscovery.RSDiscoveryError)


def test_bad_arguments_are_value_errors_before_any_request(tmp_path):
    """Nothing listens on this endpoint: each call fails on its arguments first."""
    ep = "unix:" + str(tmp_path / "nobody.sock")
    c = rsdiscovery.Client(ep)
    for kwargs in ({"domain": 233}, {"domain": -1}, {"domain": "0"}, {"domain": True}, {"product_line": ""},
                   {"product_line": 400}, {"source": "bluetooth"}):
        with pytest.raises(ValueError):
            c.list_devices(**kwargs)
        with pytest.raises(ValueError):
            c.wait_for(timeout=1, **kwargs)
        with pytest.raises(ValueError):
            c.watcher(**kwargs)
    for call in (lambda: c.get_device(""), lambda: c.get_device(None),
                 lambda: c.wait_for(timeout=-1), lambda: c.wait_for(count=0), lambda: c.wait_for(predicate=5),
                 lambda: c.watcher(last_event_id=-3), lambda: rsdiscovery.Client(ep, timeout=0),
                 lambda: rsdiscovery.Client(ep, complete_timeout=-1), lambda: rsdiscovery.Client("ftp://x")):
        with pytest.raises(ValueError):
            call()
    # A filter in any case is fine (the daemon compares ignoring case); no daemon: not running.
    with pytest.raises(rsdiscovery.DaemonNotRunning):
        c.list_devices(source="USB", product_line="d400", domain=0)


def test_python_m_rsdiscovery(daemon_factory, server_factory):
    import subprocess
    import sys
    d = daemon_factory()
    ep = "unix:" + d.socket

    def cli(*args):
        return subprocess.run([sys.executable, "-m", "rsdiscovery", "--endpoint", ep] + list(args),
                              capture_output=True, text=True, timeout=60)

    r = cli("wait", "--timeout", "0.3")
    assert r.returncode == 1 and "0 of 1" in r.stderr, r
    server_factory([info(1)])
    r = cli("--json", "wait", "--timeout", "20", "--product-line", "d400")
    assert r.returncode == 0, r
    device = json.loads(r.stdout)
    assert device["serial"] == "9876543201"
    r = cli("list")
    assert r.returncode == 0 and r.stdout.splitlines()[0].split() == ["ID", "NAME", "SERIAL", "SOURCE", "STATE"]
    assert device["id"] in r.stdout
    r = cli("--json", "get", "9876543201")
    assert r.returncode == 0 and json.loads(r.stdout)["id"] == device["id"]
    assert cli("get", "nope").returncode == 1
    assert cli("list", "--domain", "300").returncode == 2
    assert cli("list", "--source", "bluetooth").returncode == 2
    r = subprocess.run([sys.executable, "-m", "rsdiscovery", "--endpoint", "unix:/nonexistent/x.sock", "health"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 3 and "/nonexistent/x.sock" in r.stderr


class RawServer:
    """An endpoint that is not the daemon: on each connection it reads one request head and
    hands the socket to answer(sock, path), which writes what it likes."""

    def __init__(self, path, answer):
        import socket
        import threading

        self.listener = socket.socket(socket.AF_UNIX)
        self.listener.bind(path)
        self.listener.listen(8)
        self.endpoint = "unix:" + path
        self.open = []
        self.answer = answer
        self.thread = threading.Thread(target=self.serve, daemon=True)
        self.thread.start()

    def serve(self):
        while True:
            try:
                conn, _ = self.listener.accept()
            except OSError:
                return
            self.open.append(conn)
            head = b""
            while b"\r\n\r\n" not in head:
                chunk = conn.recv(4096)
                if not chunk:
                    break
                head += chunk
            parts = head.split(b" ")
            self.answer(conn, parts[1].decode() if len(parts) > 1 else "")

    @staticmethod
    def flood(conn, chunk):
        """Writes chunk again and again until the client goes."""
        try:
            while True:
                conn.sendall(chunk)
        except OSError:
            pass

    def close(self):
        import socket

        self.listener.shutdown(socket.SHUT_RDWR)
        self.listener.close()
        for c in self.open:
            c.close()


def test_answers_beyond_the_bound_are_refused_not_read(tmp_path):
    mib = b" " * (1 << 20)
    head = b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\n"
    answers = {
        "a length beyond the bound": lambda c, p: c.sendall(head + b"Content-Length: 1000000000000\r\n\r\n{"),
        "chunks without end": lambda c, p: (c.sendall(head + b"Transfer-Encoding: chunked\r\n\r\n"),
                                            RawServer.flood(c, b"100000\r\n" + mib + b"\r\n")),
        "a body until a close that never comes": lambda c, p: (c.sendall(head + b"\r\n"), RawServer.flood(c, mib)),
    }
    for n, (what, answer) in enumerate(answers.items()):
        server = RawServer(str(tmp_path / f"raw{n}.sock"), answer)
        try:
            with pytest.raises(rsdiscovery.MalformedReply,
                               match="the answer to GET /v1/devices is larger than 64 MiB"):
                rsdiscovery.list_devices(endpoint=server.endpoint, complete_timeout=0)
        finally:
            server.close()


def test_an_endless_event_ends_the_watch(tmp_path):
    listed = json.dumps({"generation": 3, "devices": [], "complete": True}).encode()

    def answer(conn, path):
        if path.startswith("/v1/devices"):
            conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: %d\r\n\r\n%s"
                         % (len(listed), listed))
            return
        conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\n\r\nevent: added\nid: 4\ndata: ")
        RawServer.flood(conn, b"x" * (1 << 20))  # one data line, never ended

    server = RawServer(str(tmp_path / "raw.sock"), answer)
    try:
        with pytest.raises(rsdiscovery.MalformedReply, match="an event larger than 16 MiB"):
            for _ in rsdiscovery.watch(endpoint=server.endpoint, reconnect=False):
                pass
    finally:
        server.close()


def test_a_character_split_between_two_reads_of_the_stream_stays_one():
    from rsdiscovery._watch import _SseParser

    text = 'event: added\nid: 7\ndata: {"id":"a","name":"Kamera Gr\u00fc\u00dfe \u2014 \U0001F4F7"}\n\n'.encode()
    for cut in range(1, len(text)):  # every place a read can end, inside a character too
        p = _SseParser()
        events = p.feed(text[:cut]) + p.feed(text[cut:])
        assert events == [("added", '{"id":"a","name":"Kamera Gr\u00fc\u00dfe \u2014 \U0001F4F7"}', "7")], cut


def test_a_camera_that_left_is_gone_not_never_seen_and_has_its_history(daemon_factory, server_factory):
    d = daemon_factory()
    server = server_factory([info(1)])
    with rsdiscovery.Client("unix:" + d.socket) as c:
        dev = c.wait_for(lambda x: x.serial == "9876543201", timeout=20)
        server.command(cmd="disconnect", **{"topic-root": dev.topic_root})  # 'stopping'
        wait_for(lambda: c.list_devices() == [], what="the camera removed")
        with pytest.raises(rsdiscovery.Gone) as gone:
            c.get_device(dev.serial)
        assert isinstance(gone.value, rsdiscovery.NotFound)  # code that caught NotFound still does
        assert gone.value.gone.reason == "stopping" and gone.value.gone.device.id == dev.id
        assert gone.value.gone.last_seen
        with pytest.raises(rsdiscovery.NotFound) as never:
            c.get_device("never-seen")
        assert not isinstance(never.value, rsdiscovery.Gone)
        h = c.device_history(dev.id)
        assert isinstance(h, rsdiscovery.DeviceHistory) and h.state == "gone" and h.gone is not None
        assert [(x.event, x.reason) for x in h.changes] == [("added", None), ("removed", "stopping")]
        assert h.removals["stopping"] == 1 and h.removals["lease-expired"] == 0 and h.flaps == 0
        whole = c.history()
        assert [x.id for x in whole.changes] == [dev.id, dev.id] and whole.next == whole.generation
        assert c.history(since=whole.next).changes == ()
        with pytest.raises(rsdiscovery.NotFound):
            c.device_history("never-seen")
