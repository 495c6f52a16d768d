"""Fixtures of the package's own tests: a real rs-discoveryd ($RSD_DAEMON) on its own
domain, socket and port, and real realdds servers (tests/tools/realdds_server.py, run
with $RSD_SERVER_PYTHON, a Python that has pyrealsense2)."""
import importlib.util
import json
import os
import socket
import subprocess
import sys
import urllib.request

import pytest

DAEMON = os.environ.get("RSD_DAEMON", "")
SERVER_PYTHON = os.environ.get("RSD_SERVER_PYTHON", sys.executable)
SERVER_TOOL = os.path.join(os.environ.get("RSD_SOURCE_DIR", ""), "tests", "tools", "realdds_server.py")
DOMAIN = int(os.environ.get("RSD_TEST_DOMAIN", "199"))


_tree_conftest = None


def wait_for(predicate, timeout=20.0, **kwargs):
    """The tree's one wait helper (tests/conftest.py's wait_for), with a longer default:
    here a daemon and a realdds server start in a fresh venv. These tests run from the tree
    (tests/client/test_python_package.py) and start its realdds server, so the helper is
    there whenever a test waits; it is loaded on first use, under a name of its own (this
    file is `conftest` too), so that test_open.py, which needs no daemon, runs without it."""
    global _tree_conftest
    if _tree_conftest is None:
        here = os.path.dirname(os.path.abspath(__file__))
        candidates = [os.path.join(os.environ.get("RSD_SOURCE_DIR", ""), "tests", "conftest.py"),
                      os.path.join(here, "..", "..", "..", "tests", "conftest.py")]
        path = next((c for c in candidates if os.path.isfile(c)), None)
        if path is None:
            pytest.fail("these tests need the rs-discoveryd tree (set RSD_SOURCE_DIR)")
        spec = importlib.util.spec_from_file_location("rsd_tree_conftest", path)
        _tree_conftest = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(_tree_conftest)
    return _tree_conftest.wait_for(predicate, timeout=timeout, **kwargs)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Daemon:
    def __init__(self, sock, log):
        self.socket = sock
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log = open(log, "ab")
        self.proc = subprocess.Popen([DAEMON, "--domain", str(DOMAIN), "--socket", sock, "--http",
                                      f"127.0.0.1:{self.port}", "--no-usb"], stdout=self.log, stderr=self.log)

        def up():
            try:
                with urllib.request.urlopen(self.url + "/v1/domains", timeout=1) as r:
                    return all(d["state"] == "running" for d in json.load(r)["domains"])
            except OSError:
                return False

        wait_for(up, what="the daemon")

    def stop(self):
        self.proc.terminate()
        self.proc.wait(10)
        self.log.close()


class Server:
    def __init__(self, infos):
        args = [SERVER_PYTHON, SERVER_TOOL, "--domain", str(DOMAIN), "--name", "py-pkg-test"]
        for i in infos:
            args += ["--device", json.dumps(i)]
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert self.proc.stdout.readline(), "realdds server did not start"

    def command(self, **msg):
        self.proc.stdin.write(json.dumps(msg) + "\n")
        self.proc.stdin.flush()
        assert json.loads(self.proc.stdout.readline()).get("ok")

    def kill(self):
        self.proc.kill()
        self.proc.wait()


def info(n):
    serial = f"98765432{n:02d}"
    return {"name": "Intel RealSense D455", "serial": serial, "product-line": "D400", "product-id": "0B5C",
            "topic-root": f"realsense/D455_{serial}"}


@pytest.fixture
def daemon_factory(tmp_path):
    started = []

    def start():
        d = Daemon(str(tmp_path / "api.sock"), str(tmp_path / "daemon.log"))
        started.append(d)
        return d

    yield start
    for d in started:
        if d.proc.poll() is None:
            d.stop()


@pytest.fixture
def server_factory():
    started = []

    def start(infos):
        s = Server(infos)
        started.append(s)
        return s

    yield start
    for s in started:
        s.kill()
