"""The messages a new user meets in the first hour, against the real daemon, the real
CLI and the Python package: what they name must be what is there. Another HTTP server
at --endpoint is named as such (not as another rs-discoveryd version); doctor's help
gives the exit statuses it really has; `describe` of a key no camera has is worded as
`get`'s; `python -m rsdiscovery` speaks of its own options, and its `health` is a line."""
import http.client
import http.server
import json
import os
import subprocess
import sys
import threading

import pytest
from client_util import DOMAIN_RANGE, SOURCE, rs_discover
from conftest import device_info, wait_for

PACKAGE_SRC = os.path.join(SOURCE, "client", "python", "src")


def python_cli(*args):
    return subprocess.run([sys.executable, "-m", "rsdiscovery", *args], capture_output=True, text=True, timeout=60,
                          env=dict(os.environ, PYTHONPATH=PACKAGE_SRC))


@pytest.fixture
def camera(daemon, realdds_server, domains):
    domain = domains.take(*DOMAIN_RANGE)
    realdds_server(domain, [device_info(71)], name="first-hour-server")
    d = daemon([domain])
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    wait_for(lambda: d.get_json("/healthz")["complete"], 20, what="the first discovery over")
    return d


@pytest.fixture
def other_server(tmp_path):
    """A plain web server (not rs-discoveryd): 404 for every path."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler)
    server.RequestHandlerClass.log_message = lambda *a: None
    os.chdir(tmp_path)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()


def test_another_http_server_is_not_called_another_version(other_server):
    said = f"something other than rs-discoveryd answers at {other_server}"
    for args in (["list"], ["health"], ["doctor", "--listen", "0"]):
        r = rs_discover(*args, endpoint=other_server)
        assert r.returncode == 4 and said in r.stdout + r.stderr, (args, r)
        assert "version mismatch" not in r.stdout + r.stderr, (args, r)
    r = python_cli("--endpoint", other_server, "list")
    assert r.returncode == 4 and said in r.stderr and "version mismatch" not in r.stderr, r


def test_doctor_help_gives_the_exit_statuses_it_has(tmp_path, other_server):
    text = " ".join(rs_discover("doctor", "--help").stdout.split())
    assert "1 a line says 'warn' or 'fail'" in text, text
    assert "3 the daemon cannot be asked" in text and "4 something other than rs-discoveryd answers" in text, text
    # What it says is what it does: 3 with no daemon, 4 against another server.
    assert rs_discover("doctor", "--listen", "0", endpoint="unix:" + str(tmp_path / "none.sock")).returncode == 3
    assert rs_discover("doctor", "--listen", "0", endpoint=other_server).returncode == 4


def test_describe_and_the_api_word_an_unknown_key_as_get_does(camera):
    ep = "unix:" + camera.socket
    got, described = rs_discover("get", "999999", endpoint=ep), rs_discover("describe", "999999", endpoint=ep)
    assert got.returncode == described.returncode == 1, (got, described)
    assert described.stderr == got.stderr, (got.stderr, described.stderr)
    assert "no device '999999'" in got.stderr and "rs-discover list -q" in got.stderr and \
        "rs-discover doctor" in got.stderr, got.stderr
    # The API's 404: the same words, and where the keys are.
    for path in ("/v1/devices/999999", "/v1/devices/999999/description"):
        conn = http.client.HTTPConnection("127.0.0.1", camera.port, timeout=10)
        conn.request("GET", path)
        resp = conn.getresponse()
        status, body = resp.status, json.loads(resp.read())
        assert status == 404 and body["error"].startswith("no device '999999' (no camera listed has it as its id, "
                                                          "serial or topic-root; GET /v1/devices lists them)"), body


def test_python_cli_names_its_option_and_prints_health_as_a_line(camera, tmp_path):
    r = python_cli("--endpoint", "unix:" + str(tmp_path / "none.sock"), "list")
    assert r.returncode == 3 and "with --endpoint or RS_DISCOVERY_ENDPOINT" in r.stderr, r
    assert "endpoint=" not in r.stderr, r
    ep = "unix:" + camera.socket
    line = rs_discover("health", endpoint=ep).stdout
    r = python_cli("--endpoint", ep, "health")
    assert r.returncode == 0 and r.stdout == line, (r.stdout, line)
    assert r.stdout.startswith("ok: rs-discoveryd ") and r.stdout.endswith(f" at {ep}, 1 device\n"), r.stdout
