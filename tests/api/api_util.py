"""Client-side helpers for the API tests: an SSE reader, raw socket requests,
curl, the Prometheus text parser and validation against proto/openapi.yaml."""
import datetime
import functools
import http.client
import json
import os
import queue
import re
import socket
import subprocess
import threading
import time

import yaml
from openapi_schema_validator import OAS30Validator

from conftest import UnixHTTPConnection, request_once

SOURCE_DIR = os.environ.get("RSD_SOURCE_DIR") or os.path.dirname(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SPEC_PATH = os.path.join(SOURCE_DIR, "proto", "openapi.yaml")


def connection(target, timeout=5.0):
    """target: a Unix socket path (str) or a (host, port) tuple."""
    if isinstance(target, tuple):
        return http.client.HTTPConnection(target[0], target[1], timeout=timeout)
    return UnixHTTPConnection(target, timeout=timeout)


def request(target, path, method="GET", headers=None, body=None, timeout=5.0):
    """Returns (status, lower-cased headers, body bytes)."""
    return request_once(connection(target, timeout), path, method, headers, body)


def get_json(target, path, expect=200):
    status, headers, body = request(target, path)
    assert status == expect, f"GET {path}: {status} {body[:300]!r}"
    assert headers["content-type"].startswith("application/json"), headers
    return json.loads(body)


def raw(target, data, timeout=3.0, half_close=True):
    """Sends bytes as they are and returns whatever comes back until EOF/timeout."""
    family = socket.AF_INET if isinstance(target, tuple) else socket.AF_UNIX
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.settimeout(timeout)
        s.connect(target)
        try:
            s.sendall(data)
            if half_close:
                s.shutdown(socket.SHUT_WR)
        except OSError:
            pass  # the server may hang up mid-send on an oversized request
        out = b""
        try:
            while True:
                chunk = s.recv(65536)
                if not chunk:
                    break
                out += chunk
        except (socket.timeout, ConnectionResetError):
            pass
        return out


def curl(target, path, *args):
    """curl over the Unix socket or TCP; returns (status, body text)."""
    cmd = ["curl", "-sS", "--max-time", "5", "-o", "-", "-w", "\n%{http_code}"]
    if isinstance(target, tuple):
        url = f"http://{target[0]}:{target[1]}{path}"
    else:
        cmd += ["--unix-socket", target]
        url = f"http://localhost{path}"
    out = subprocess.run(cmd + list(args) + [url], capture_output=True, text=True, timeout=10)
    assert out.returncode == 0, out.stderr
    body, _, code = out.stdout.rpartition("\n")
    return int(code), body


class SSEStream:
    """Reads an event stream on a thread; next() hands out parsed messages:
    {"event", "id", "data"} dicts, {"comment": text} for comment lines, and None
    once the stream has ended."""

    def __init__(self, target, path="/v1/events", headers=None):
        self.conn = connection(target, timeout=60)
        self.conn.request("GET", path, headers=headers or {})
        self.resp = self.conn.getresponse()
        self.status = self.resp.status
        self.headers = {k.lower(): v for k, v in self.resp.getheaders()}
        self.queue = queue.Queue()
        if self.status == 200:
            self.thread = threading.Thread(target=self._read, daemon=True)
            self.thread.start()
        else:
            self.body = self.resp.read()

    def _read(self):
        msg = {}
        try:
            while True:
                line = self.resp.readline()
                if not line:
                    break
                line = line.decode("utf-8").rstrip("\r\n")
                if line == "":
                    # As in EventSource: a block without data (e.g. only retry:) is
                    # not an event.
                    if "data" in msg:
                        self.queue.put(msg)
                    msg = {}
                elif line.startswith(":"):
                    self.queue.put({"comment": line[1:].strip()})
                else:
                    field, _, value = line.partition(":")
                    value = value[1:] if value.startswith(" ") else value
                    if field == "data" and "data" in msg:
                        msg["data"] += "\n" + value
                    else:
                        msg[field] = value
        except Exception:  # noqa: BLE001 - close() from another thread breaks the read any which way
            pass
        self.queue.put(None)

    def next(self, timeout=10.0, comments=False):
        """The next message (skipping comments unless asked for); fails at the deadline."""
        deadline = _now() + timeout
        while True:
            left = deadline - _now()
            try:
                msg = self.queue.get(timeout=max(0.0, left))
            except queue.Empty:
                raise AssertionError(f"no SSE message within {timeout}s") from None
            if msg is None or comments or "comment" not in msg:
                return msg

    def next_event(self, timeout=10.0):
        msg = self.next(timeout)
        assert msg is not None, "the event stream ended"
        if "data" in msg:
            msg["json"] = json.loads(msg["data"])
        return msg

    def close(self):
        try:
            if self.conn.sock:
                self.conn.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self.conn.close()


def _now():
    return time.monotonic()


_SAMPLE = re.compile(r'^([a-zA-Z_:][a-zA-Z0-9_:]*)(?:\{(.*)\})? (\S+)$')
_LABEL = re.compile(r'([a-zA-Z_][a-zA-Z0-9_]*)="((?:[^"\\]|\\.)*)"(?:,|$)')


def parse_metrics(text):
    """Parses Prometheus text; returns {(name, ((label, value), ...)): float} and
    checks that every sample belongs to a family declared with # TYPE."""
    types = {}
    samples = {}
    for line in text.splitlines():
        if not line:
            continue
        if line.startswith("# TYPE "):
            _, _, name, kind = line.split(" ", 3)
            assert kind in ("counter", "gauge", "histogram", "summary", "untyped"), line
            assert name not in types, f"family declared twice: {name}"
            types[name] = kind
            continue
        if line.startswith("#"):
            continue
        m = _SAMPLE.match(line)
        assert m, f"not a sample line: {line!r}"
        name, labels, value = m.groups()
        assert name in types, f"sample without # TYPE: {line!r}"
        pairs = tuple(sorted(_LABEL.findall(labels or "")))
        samples[(name, pairs)] = float(value)
    return samples


def metric(samples, name, **labels):
    return samples.get((name, tuple(sorted(labels.items()))))


@functools.lru_cache(maxsize=None)
def spec():
    with open(SPEC_PATH, encoding="utf-8") as f:
        return yaml.safe_load(f)


def _resolve(node):
    while isinstance(node, dict) and "$ref" in node:
        node = functools.reduce(lambda d, k: d[k], node["$ref"].lstrip("#/").split("/"), spec())
    return node


def schema_validator(ref):
    """A validator for '#/components/schemas/X' that resolves the spec's refs."""
    return OAS30Validator({"$ref": ref, "components": spec()["components"]})


def validate_response(path, status, body, method="get"):
    """Validates a JSON body against the spec's response for path/method/status."""
    op = spec()["paths"][path][method]
    response = _resolve(op["responses"][str(status)])
    schema = response["content"]["application/json"]["schema"]
    OAS30Validator({**schema, "components": spec()["components"]}).validate(body)
    if path.startswith("/v1/devices") and not path.endswith(("/history", "/clients")):
        for device in body.get("devices", [body]) if status == 200 else []:
            check_timestamps(device)


def check_timestamps(device):
    """first-seen/last-seen are RFC 3339 UTC and ordered."""
    rfc3339 = re.compile(r"^\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d+)?(Z|[+-]\d{2}:\d{2})$")
    stamps = []
    for key in ("first-seen", "last-seen"):
        assert rfc3339.match(device[key]), f"{key}: {device[key]!r}"
        stamps.append(datetime.datetime.fromisoformat(device[key].replace("Z", "+00:00")))
    assert stamps[0] <= stamps[1], device
