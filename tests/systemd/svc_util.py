"""Helpers for the systemd tests: a test-owned NOTIFY_SOCKET, config files."""
import json
import os
import queue
import socket
import threading
import time

import pytest

SOURCE_DIR = os.environ.get("RSD_SOURCE_DIR", os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
SANITIZED = os.environ.get("RSD_SANITIZE", "0") in ("1", "ON", "TRUE", "true")


class NotifySocket:
    """A Unix datagram socket standing in for systemd's notification socket.

    Every datagram is parsed into a dict of its KEY=VALUE lines and kept, in order."""

    def __init__(self, path):
        self.path = path
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(path)
        self.sock.settimeout(0.2)
        self.messages = []  # (monotonic time, dict)
        self._queue = queue.Queue()
        self._stop = False
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self):
        while not self._stop:
            try:
                data = self.sock.recv(65536)
            except socket.timeout:
                continue
            except OSError:
                break
            fields = dict(line.split("=", 1) for line in data.decode().split("\n") if "=" in line)
            entry = (time.monotonic(), fields)
            self.messages.append(entry)
            self._queue.put(entry)

    def env(self, watchdog_usec=None):
        e = {"NOTIFY_SOCKET": self.path}
        if watchdog_usec:
            e["WATCHDOG_USEC"] = str(watchdog_usec)
        return e

    def wait(self, predicate, timeout=15.0, what="a notification"):
        """The first message from now on for which predicate(fields) holds."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                pytest.fail(f"no {what} within {timeout}s; got {[m for _, m in self.messages][-8:]}")
            try:
                _, fields = self._queue.get(timeout=left)
            except queue.Empty:
                continue
            if predicate(fields):
                return fields

    def seen_within(self, predicate, timeout):
        """Like wait(), but None at the deadline: for checking that something does not come."""
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            try:
                _, fields = self._queue.get(timeout=left)
            except queue.Empty:
                break
            if predicate(fields):
                return fields
        return None

    def drain(self):
        while True:
            try:
                self._queue.get_nowait()
            except queue.Empty:
                return

    def all(self, key):
        return [m[key] for _, m in self.messages if key in m]

    def close(self):
        self._stop = True
        self.sock.close()
        self._thread.join(2)


@pytest.fixture
def notify_socket(tmp_path):
    n = NotifySocket(str(tmp_path / "notify.sock"))
    yield n
    n.close()


def write_config(path, **settings):
    tmp = str(path) + ".tmp"
    with open(tmp, "w") as f:
        json.dump(settings, f)
    os.replace(tmp, path)  # a reload never sees a half-written file
