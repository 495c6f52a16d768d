"""What rs-discover prints, against the real daemon and real realdds servers:
--format on list, get and participants, with nested fields and an unknown field an
error; `get` pointing to `doctor`; the loopback HTTP endpoint used when the default
socket is missing or refused (and both named when neither answers); watch --initial's
rows, `changed` lines in words, and one line per outage."""
import json
import os
import re
import signal
import socket
import subprocess
import uuid

import pytest
from client_util import CLI, DOMAIN_RANGE, WatchProcess, rs_discover
from conftest import DAEMON, device_info, wait_for


@pytest.fixture
def camera(daemon, realdds_server, domains):
    domain = domains.take(*DOMAIN_RANGE)
    info = device_info(41, **{"custom-field": "kept as sent"})
    server = realdds_server(domain, [info], name="format-server")
    d = daemon([domain])
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    return d, "unix:" + d.socket, info, server


def test_format_nested_fields_unknown_ones_and_on_get_and_participants(camera):
    d, ep, info, _ = camera
    device = d.devices()[0]
    addresses = device["server"]["addresses"]
    r = rs_discover("list", "--format", "{serial} {server.addresses} {server.participant-name} {sources} {usb.port-path}|",
                    endpoint=ep)
    assert r.returncode == 0, r.stderr
    assert r.stdout == f"{info['serial']} {','.join(addresses)} format-server dds |\n"  # lists joined, absent empty
    # A key of the camera's own device-info that the API does not document still works.
    assert rs_discover("list", "-f", "{custom-field}", endpoint=ep).stdout == "kept as sent\n"
    for command in (["list"], ["get", info["serial"]]):
        r = rs_discover(*command, "--format", "{serial} {fw_version}", endpoint=ep)
        assert r.returncode == 2 and r.stdout == "", (command, r)
        assert "unknown field '{fw_version}'" in r.stderr and "{fw-version}" in r.stderr and \
            "{server.addresses}" in r.stderr, r.stderr
    r = rs_discover("get", "--format", "{id}\\t{server.participant-name}\\t{state}", info["serial"], endpoint=ep)
    assert r.returncode == 0 and r.stdout == f"{device['id']}\tformat-server\tok\n", r
    r = rs_discover("participants", "--format", "{name} {vendor} {addresses} {devices} {topic-roots}", endpoint=ep)
    assert r.returncode == 0, r.stderr
    part = next(p for p in d.get_json("/v1/participants")["participants"] if p.get("name") == "format-server")
    assert f"format-server fast-dds {','.join(part['addresses'])} 1 {info['topic-root']}" in r.stdout.splitlines()
    r = rs_discover("participants", "--format", "{serial}", endpoint=ep)
    assert r.returncode == 2 and "unknown field '{serial}'" in r.stderr and "{vendor}" in r.stderr, r
    assert "--format" in rs_discover("get", "--help").stdout and "--format" in rs_discover("participants", "--help").stdout


def test_get_points_to_doctor_when_nothing_matches(camera):
    _, ep, _, _ = camera
    r = rs_discover("get", "no-such-camera", endpoint=ep)
    assert r.returncode == 1 and "no device 'no-such-camera'" in r.stderr and "rs-discover doctor" in r.stderr, r


@pytest.fixture
def loopback_host(tmp_path):
    """A network namespace of its own (only `lo`), so a daemon there may take the
    default HTTP port 127.0.0.1:8035 whatever runs on this machine: a command prefix."""
    name = "rsd-fallback-" + uuid.uuid4().hex[:8]
    subprocess.run(["ip", "netns", "add", name], check=True)
    try:
        subprocess.run(["ip", "-n", name, "link", "set", "lo", "up"], check=True)
        yield ["ip", "netns", "exec", name]
    finally:
        subprocess.run(["ip", "netns", "del", name])


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root for a network namespace")
def test_the_loopback_http_endpoint_when_the_default_socket_is_missing_or_refused(loopback_host, domains, tmp_path):
    domain = domains.take(*DOMAIN_RANGE)
    config = tmp_path / "empty.json"
    config.write_text("{}")
    log = open(tmp_path / "daemon.log", "wb")
    daemon_socket = str(tmp_path / "elsewhere.sock")  # not where a client looks by default
    proc = subprocess.Popen(loopback_host + [DAEMON, "--config", str(config), "--domain", str(domain), "--socket",
                                             daemon_socket, "--http", "127.0.0.1:8035", "--no-usb"],
                            stdout=log, stderr=subprocess.STDOUT)
    runtime = tmp_path / "runtime"
    runtime.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "RS_DISCOVERY_ENDPOINT"}
    env["RUNTIME_DIRECTORY"] = str(runtime)  # the default socket: runtime/api.sock, missing

    def cli(*args):
        return subprocess.run(loopback_host + [CLI] + list(args), capture_output=True, text=True, env=env, timeout=30)

    try:
        wait_for(lambda: os.path.exists(daemon_socket), 15, what="the daemon up")
        r = wait_for(lambda: (lambda r: r if r.returncode == 0 else None)(cli("health")), 15, what="an answer")
        assert "http://127.0.0.1:8035" in r.stdout, r.stdout
        assert r.stderr == f"rs-discover: no socket at {runtime}/api.sock; using http://127.0.0.1:8035\n", r.stderr
        r = cli("list", "--json")
        assert r.returncode == 0 and json.loads(r.stdout)["devices"] == [], r
        assert r.stderr.count("using http://127.0.0.1:8035") == 1
        # A stale socket file (nothing listens): refused, the same way out.
        stale = socket.socket(socket.AF_UNIX)
        stale.bind(str(runtime / "api.sock"))
        stale.close()
        r = cli("domains")
        assert r.returncode == 0 and f"nothing listens on {runtime}/api.sock; using http://127.0.0.1:8035" in r.stderr, r
        # Neither answers: the error names both.
        proc.send_signal(signal.SIGTERM)
        proc.wait(10)
        r = cli("list")
        assert r.returncode == 3, r
        assert f"nothing listens on {runtime}/api.sock" in r.stderr and "nothing answers at http://127.0.0.1:8035" in r.stderr, \
            r.stderr
        # An endpoint given is used as given, with no second guess.
        r = cli("--endpoint", f"unix:{runtime}/api.sock", "list")
        assert r.returncode == 3 and "8035" not in r.stderr, r.stderr
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        log.close()


def test_watch_initial_rows_changes_in_words_and_one_line_per_outage(daemon, realdds_server, domains, tmp_path):
    domain = domains.take(*DOMAIN_RANGE)
    info = device_info(42)
    realdds_server(domain, [info], name="first-server")
    sock = str(tmp_path / "watch.sock")
    d = daemon([domain], socket=sock)
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    device_id = d.devices()[0]["id"]
    r = rs_discover("watch", "--initial", "--json", "--count", "1", "--timeout", "20", endpoint="unix:" + sock)
    assert r.returncode == 0 and json.loads(r.stdout) | {"id": 0} == {
        "event": "added", "id": 0, "synthetic": True, "initial": True, "device": json.loads(r.stdout)["device"]}, r

    watch = WatchProcess("unix:" + sock, "--initial")
    lines, errors = watch.lines, watch.errors
    first = wait_for(lambda: lines[0] if lines else None, 20, what="the initial row")
    assert f" added   {device_id} " in first and "(present at start)" in first and "re-listed" not in first, first

    # The daemon goes; in its place a socket that takes each connection and closes it,
    # so every reconnection attempt fails: several attempts, one line.
    d.stop()
    attempts = []
    trap = socket.socket(socket.AF_UNIX)
    if os.path.exists(sock):
        os.unlink(sock)
    trap.bind(sock)
    trap.listen(16)
    trap.settimeout(0.2)

    def refuse():
        while len(attempts) < 4:
            try:
                c, _ = trap.accept()
            except socket.timeout:
                continue
            attempts.append(1)
            c.close()
    refuse()
    trap.close()
    os.unlink(sock)
    d2 = daemon([domain], socket=sock)
    wait_for(lambda: len(d2.devices()) == 1, 20, what="the camera in the restarted daemon")
    wait_for(lambda: any("connected again" in x for x in errors), 30, what="the watch back")

    # A second server announces the camera with new firmware: the line says so in words.
    realdds_server(domain, [dict(info, **{"fw-version": "5.16.1.0"})], name="second-server")
    changed = wait_for(lambda: next((x for x in lines if " changed " in x), None), 30, what="the changed line")
    assert watch.interrupt() == 0, errors
    assert "fw-version 5.16.0.1 \u2192 5.16.1.0" in changed and "now served by second-server (" in changed, changed
    assert "{" not in changed and '"' not in changed, changed  # words, not JSON
    lost = [x for x in errors if "lost the daemon" in x]
    assert len(lost) == 1 and len([x for x in errors if "connected again" in x]) == 1, errors
    assert re.search(r"connected again after \d+\.\d s", "".join(errors)), errors
