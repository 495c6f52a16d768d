"""Fixtures shared by every pytest suite: each test gets its own DDS domain,
Unix socket and TCP port, so suites run in parallel and never see each other.

- free_domain: a DDS domain id held (by an flock) for the test's lifetime.
- daemon: factory starting the real rs-discoveryd binary ($RSD_DAEMON).
- realdds_server: factory starting tests/tools/realdds_server.py (real realdds).
- wait_for(): polls a condition until a deadline; never a bare sleep. The one wait
  helper of the Python tests (api_util and client/python/tests use this one too).
"""
import fcntl
import http.client
import json
import os
import random
import signal
import socket
import subprocess
import sys
import tempfile
import time

import pytest

TESTS_DIR = os.path.dirname(os.path.abspath(__file__))
DAEMON = os.environ.get("RSD_DAEMON", os.path.join(os.environ.get("RSD_BUILD_DIR", ""), "daemon", "rs-discoveryd"))
LOCK_DIR = os.path.join(tempfile.gettempdir(), "rsd-test-domains")


def wait_for(predicate, timeout=10.0, interval=0.02, what="condition", fail=True):
    """Returns predicate()'s first truthy value; fails the test at the deadline
    (or, with fail=False, returns the last falsy value)."""
    deadline = time.monotonic() + timeout
    last = None
    while time.monotonic() < deadline:
        last = predicate()
        if last:
            return last
        time.sleep(interval)
    if not fail:
        return last
    pytest.fail(f"timed out after {timeout}s waiting for {what} (last: {last!r})")


class UnixHTTPConnection(http.client.HTTPConnection):
    def __init__(self, path, timeout=5.0):
        super().__init__("localhost", timeout=timeout)
        self.path = path

    def connect(self):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(self.timeout)
        s.connect(self.path)
        self.sock = s


def request_once(conn, path, method="GET", headers=None, body=None):
    """One request on `conn`, which is closed after: (status, lower-cased headers, body bytes)."""
    try:
        conn.request(method, path, body=body, headers=headers or {})
        r = conn.getresponse()
        return r.status, {k.lower(): v for k, v in r.getheaders()}, r.read()
    finally:
        conn.close()


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class DomainLocks:
    """DDS domain ids handed out across parallel test processes: 1..100 only.

    Domain d's RTPS ports are 7400 + 250*d + 0..249; from domain 101 on they fall
    in Linux's ephemeral port range (32768-60999), where any outgoing socket on
    the machine may hold one: a daemon on domain 166 once found its discovery
    port 48900 taken ("address in use")."""

    def __init__(self):
        os.makedirs(LOCK_DIR, exist_ok=True)
        self.held = []

    def take(self, lo=1, hi=59):  # 60-79: systemd and packaging, 80-100: client; 232: unit
        ids = list(range(lo, hi + 1))
        random.shuffle(ids)
        for d in ids:
            f = open(os.path.join(LOCK_DIR, f"{d}.lock"), "w")
            try:
                fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                f.close()
                continue
            self.held.append(f)
            return d
        pytest.fail("no free DDS domain id for the test")

    def release(self):
        for f in self.held:
            f.close()
        self.held.clear()


@pytest.fixture
def domains():
    locks = DomainLocks()
    yield locks
    locks.release()


@pytest.fixture
def free_domain(domains):
    return domains.take()


class Daemon:
    def __init__(self, args, tmpdir, socket_path, port, env=None, prefix=()):
        self.socket = socket_path
        self.port = port
        self.url = f"http://127.0.0.1:{port}" if port else None
        self.log_path = os.path.join(tmpdir, f"daemon-{time.monotonic_ns()}.log")
        self._log = open(self.log_path, "wb")
        full_env = dict(os.environ)
        full_env.update(env or {})
        # `prefix`: e.g. `ip netns exec NS`, to run the daemon on another test host.
        self.proc = subprocess.Popen(list(prefix) + [DAEMON] + args, stdout=self._log, stderr=subprocess.STDOUT,
                                     env=full_env)

    def log(self):
        with open(self.log_path, "rb") as f:
            return f.read().decode("utf-8", "replace")

    def request(self, path, method="GET", via="unix", headers=None, body=None, timeout=5.0):
        """Returns (status, headers dict, body bytes)."""
        if via == "unix":
            conn = UnixHTTPConnection(self.socket, timeout=timeout)
        else:
            conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout)
        return request_once(conn, path, method, headers, body)

    def get_json(self, path, via="unix", expect=200):
        status, _, body = self.request(path, via=via)
        assert status == expect, f"GET {path}: {status} {body[:300]!r}"
        return json.loads(body)

    def devices(self, query="", via="unix"):
        return self.get_json("/v1/devices" + query, via=via)["devices"]

    def device_ids(self, query=""):
        return sorted(d["id"] for d in self.devices(query))

    def healthy(self):
        try:
            return self.request("/healthz", timeout=1.0)[0] == 200
        except OSError:
            return False

    def wait_ready(self, timeout=15.0):
        def ok():
            if self.proc.poll() is not None:
                pytest.fail(f"daemon exited with {self.proc.returncode}:\n{self.log()}")
            return self.healthy() and all(d["state"] == "running" for d in self.get_json("/v1/domains")["domains"])
        wait_for(ok, timeout, what="daemon ready (API up, every domain reading)")
        return self

    def signal(self, sig):
        self.proc.send_signal(sig)

    def stop(self, timeout=5.0):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._log.close()
        return self.proc.returncode


@pytest.fixture
def daemon(tmp_path):
    """daemon(domains=[..], extra=[..], wait=True) -> Daemon, stopped after the test.
    USB is off unless usb=True (the host's bus is no test's)."""
    started = []

    def start(domains, extra=(), wait=True, http=True, env=None, socket=None, prefix=(), usb=False):
        sock = socket or os.path.join(tmp_path, f"api-{len(started)}.sock")
        port = free_port() if http else None
        args = []
        for d in domains:
            args += ["--domain", str(d)]
        # An explicit, empty config: /etc/rs-discoveryd/config.json (the package
        # test installs one for a while) must not reach into other tests.
        empty = os.path.join(tmp_path, "empty-config.json")
        with open(empty, "w") as f:
            f.write("{}")
        args += ["--config", empty, "--socket", sock, "--http", f"127.0.0.1:{port}" if port else "off",
                 "--log-level", "debug"] + ([] if usb else ["--no-usb"])
        args += list(extra)
        d = Daemon(args, str(tmp_path), sock, port, env, prefix)
        started.append(d)
        if wait:
            d.wait_ready()
        return d

    yield start
    for d in started:
        code = d.stop()
        # ASan/UBSan findings make the daemon exit non-zero: fail the test on them.
        assert code in (0, -signal.SIGKILL), f"daemon exited with {code}:\n{d.log()[-4000:]}"


class RealddsServer:
    def __init__(self, domain, devices, name="test-server", prefix=()):
        args = list(prefix) + [sys.executable, os.path.join(TESTS_DIR, "tools", "realdds_server.py"), "--domain", str(domain),
                "--name", name]
        for info in devices:
            args += ["--device", json.dumps(info)]
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.hello = self._reply()

    def _reply(self):
        # realdds logs to stdout too ("-E- ..."): the tool's replies are the JSON lines.
        while True:
            line = self.proc.stdout.readline()
            assert line, "realdds server exited"
            if line.startswith("{"):
                return json.loads(line)

    def command(self, **msg):
        self.proc.stdin.write(json.dumps(msg) + "\n")
        self.proc.stdin.flush()
        reply = self._reply()
        assert reply.get("ok"), reply
        return reply

    def quit(self):
        if self.proc.poll() is None:
            self.command(cmd="quit")
            self.proc.wait(10)

    def kill(self):
        self.proc.kill()
        self.proc.wait()


# Under AddressSanitizer freed memory sits in its quarantine (256 MB) and every
# allocation has shadow: RSS says nothing about the daemon there. Tests that bound
# RSS do so on the plain build only.
SANITIZED = bool(os.environ.get("RSD_SANITIZER_FLAGS"))


def rss_kb(pid):
    """The resident set of process `pid`, in KiB."""
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise AssertionError("no VmRSS")


def device_info(n, serial=None, **extra):
    """A device-info as a D455 camera sends it."""
    serial = serial or f"1236222707{n:02d}"
    info = {"name": "Intel RealSense D455", "serial": serial, "product-line": "D400", "product-id": "0B5C",
            "fw-version": "5.16.0.1", "topic-root": f"realsense/D455_{serial}"}
    info.update(extra)
    return info


@pytest.fixture
def realdds_server():
    """realdds_server(domain, [device-info...], name=...) -> RealddsServer."""
    servers = []

    def start(domain, devices, name="test-server", prefix=()):
        s = RealddsServer(domain, devices, name, prefix)
        servers.append(s)
        return s

    yield start
    for s in servers:
        if s.proc.poll() is None:
            s.kill()


class JsonLinesProcess:
    """A child process whose stdout is JSON lines, read on a thread into `lines`
    (None once stdout ends)."""

    def __init__(self, args, **popen):
        import queue
        import threading

        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, text=True, **popen)
        self.lines = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.proc.stdout:
            self.lines.put(json.loads(line))
        self.lines.put(None)

    def drain(self):
        """Every line read so far (waits for none); fails the test if the process ended."""
        import queue

        out = []
        while True:
            try:
                item = self.lines.get_nowait()
            except queue.Empty:
                return out
            assert item is not None, f"{self.proc.args[0]} ended"
            out.append(item)


class EventStream:
    """A client of /v1/events, read on a thread so tests can wait with deadlines.
    Each event carries "t", the time.monotonic() its last line was read at."""

    def __init__(self, daemon, last_event_id=None, via="unix", query=""):
        import queue
        import threading

        self.events = queue.Queue()
        self.comments = 0
        headers = {"Accept": "text/event-stream"}
        if last_event_id is not None:
            headers["Last-Event-ID"] = str(last_event_id)
        if via == "unix":
            self.conn = UnixHTTPConnection(daemon.socket, timeout=60)
        else:
            self.conn = http.client.HTTPConnection("127.0.0.1", daemon.port, timeout=60)
        self.conn.request("GET", "/v1/events" + query, headers=headers)
        self.response = self.conn.getresponse()
        assert self.response.status == 200, self.response.status
        self.content_type = self.response.getheader("Content-Type", "")
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self):
        event = {}
        try:
            while True:
                line = self.response.fp.readline()
                if not line:
                    break
                line = line.decode("utf-8").rstrip("\r\n")
                if line == "":
                    if event:
                        event["t"] = time.monotonic()
                        if "data" in event:
                            try:
                                event["json"] = json.loads(event["data"])
                            except ValueError:
                                pass
                        self.events.put(event)
                    event = {}
                elif line.startswith(":"):
                    self.comments += 1
                else:
                    key, _, value = line.partition(":")
                    value = value[1:] if value.startswith(" ") else value
                    event[key] = event.get(key, "") + ("\n" if key == "data" and key in event else "") + value
        except (OSError, ValueError):
            pass
        self.events.put(None)  # end of stream

    def next(self, timeout=10.0, types=("added", "changed", "removed", "resync")):
        """The next event of one of `types` (others, such as hello, are skipped)."""
        import queue

        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                pytest.fail(f"no {types} event within {timeout}s")
            try:
                ev = self.events.get(timeout=left)
            except queue.Empty:
                pytest.fail(f"no {types} event within {timeout}s")
            if ev is None:
                pytest.fail("event stream ended")
            if ev.get("event") in types:
                return ev

    def within(self, seconds, types=("changed",)):
        """Every event of one of `types` the stream brings in the next `seconds`."""
        import queue

        out, deadline = [], time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0:
            try:
                ev = self.events.get(timeout=left)
            except queue.Empty:
                break
            if ev is None:
                pytest.fail("event stream ended")
            if ev.get("event") in types:
                out.append(ev)
        return out

    def close(self):
        try:
            self.conn.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.conn.close()


class CyclonePeer(JsonLinesProcess):
    """tests/tools/cyclone_peer.py: PyPI's Cyclone DDS 11 on a flexible topic (see there)."""

    def __init__(self, domain, role, octet, topic, extra=()):
        super().__init__([sys.executable, os.path.join(TESTS_DIR, "tools", "cyclone_peer.py"), "--domain",
                          str(domain), "--octet", octet, "--topic", topic, *extra, role], stdin=subprocess.PIPE)

    def next(self, timeout=30):
        import queue

        try:
            line = self.lines.get(timeout=timeout)
        except queue.Empty:
            pytest.fail(f"the Cyclone peer said nothing within {timeout}s")
        assert line is not None, "the Cyclone peer exited"
        return line

    def send(self, **msg):
        self.proc.stdin.write(json.dumps(msg) + "\n")
        self.proc.stdin.flush()
        assert self.next() == {"ok": True}

    def close(self):
        if self.proc.poll() is None:
            self.proc.stdin.close()
            self.proc.wait(10)


@pytest.fixture
def cyclone_peer():
    """cyclone_peer(domain, "writer"|"reader"|"announcer", octet="uint8", topic=device-info,
    extra=[more arguments]) -> CyclonePeer."""
    peers = []

    def start(domain, role, octet="uint8", topic="realsense/device-info", extra=()):
        p = CyclonePeer(domain, role, octet, topic, extra)
        peers.append(p)
        return p

    yield start
    for p in peers:
        if p.proc.poll() is None:
            p.proc.kill()
            p.proc.wait()
