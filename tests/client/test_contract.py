"""One contract for the daemon and its clients (issue 9): filters are the daemon's alone,
lookups by id, serial or topic-root answer the same everywhere, `list --json` is the
API's answer, and the default socket is the same for the daemon and both clients.
Every check talks to the real daemon, with real realdds servers as the cameras."""
import json
import os
import pwd
import subprocess
import sys
import tempfile
import threading
import urllib.parse

import pytest
from client_util import CLI, DOMAIN_RANGE, SOURCE, rs_discover
from conftest import DAEMON, JsonLinesProcess, device_info, wait_for

sys.path.insert(0, os.path.join(SOURCE, "client", "python", "src"))
import rsdiscovery  # noqa: E402  (the package as shipped: standard library only)


@pytest.fixture
def domain(domains):
    return domains.take(*DOMAIN_RANGE)


def test_filters_are_the_daemons_and_ignore_case(daemon, realdds_server, domain):
    d = daemon([domain])
    ep = "unix:" + d.socket
    # The waits start on a complete table and before the cameras are up, so they must see
    # them arrive (through their watches), not find them in their first list.
    wait_for(lambda: d.get_json("/healthz")["complete"], 10, what="the daemon's first discovery over")
    waiting = subprocess.Popen([CLI, "--endpoint", ep, "list", "--product-line", "d400", "--wait", "2",
                                "--timeout", "30", "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # --initial: cameras already there when it starts are reported too, so the check does
    # not depend on when the watch connects.
    watch = JsonLinesProcess([CLI, "--endpoint", ep, "watch", "--json", "--initial", "--product-line", "d400"])
    client = rsdiscovery.Client("unix:" + d.socket)
    found = []
    python_wait = threading.Thread(
        target=lambda: found.append(client.wait_for(product_line="d400", count=2, timeout=30)))
    python_wait.start()
    try:
        realdds_server(domain, [device_info(1), device_info(2)], name="filter-server")
        python_wait.join(40)
        assert found and found[0] is not None and found[0].product_line == "D400"
        out, err = waiting.communicate(timeout=40)
        assert waiting.returncode == 0, err
        assert len(out.split()) == 2
        added = []
        wait_for(lambda: added.extend(e for e in watch.drain() if e["event"] == "added") or len(added) >= 2, 20,
                 what="two added events through watch --product-line d400")
        assert sorted(e["device"]["id"] for e in added) == d.device_ids()
        # The same one rule for the source's case, and for what a route does not take.
        assert [x.id for x in client.list_devices(source="DDS")] == d.device_ids()
        assert rs_discover("list", "-q", "--product-line", "D400", endpoint=ep).stdout.split() == d.device_ids()
        for path in ("/healthz", "/metrics", "/v1/domains", "/v1/devices?domian=1",
                     "/v1/devices/" + d.device_ids()[0] + "?x=1"):
            status, _, body = d.request(path + ("&" if "?" in path else "?") + "typo=1")
            assert status == 400, (path, status, body)
            assert "typo" in json.loads(body)["error"] or "domian" in json.loads(body)["error"]
    finally:
        waiting.kill()
        watch.proc.kill()


def test_lookup_by_id_serial_or_topic_root_everywhere(daemon, realdds_server, domain):
    d = daemon([domain])
    ep = "unix:" + d.socket
    one, twin_a, twin_b = device_info(1), device_info(2, serial="777"), device_info(3, serial="777")
    twin_b["topic-root"] = "realsense/D455_777_b"
    realdds_server(domain, [one, twin_a, twin_b], name="lookup-server")
    wait_for(lambda: len(d.device_ids()) == 3, 20, what="three devices")
    [dev] = [x for x in d.devices() if x["serial"] == one["serial"]]
    client = rsdiscovery.Client("unix:" + d.socket)
    for key in (dev["id"], one["serial"], one["topic-root"]):
        assert d.get_json("/v1/devices/" + urllib.parse.quote(key, safe=""))["id"] == dev["id"], key
        assert client.get_device(key).id == dev["id"], key
        r = rs_discover("get", "--json", key, endpoint=ep)
        assert r.returncode == 0, (key, r.stderr)
        assert json.loads(r.stdout)["id"] == dev["id"]
    # A serial of two cameras names neither: the API says which ids it could mean.
    status, _, body = d.request("/v1/devices/777")
    assert status == 409
    ids = sorted(x["id"] for x in d.devices() if x["serial"] == "777")
    assert sorted(json.loads(body)["ids"]) == ids
    with pytest.raises(rsdiscovery.NotFound) as e:
        client.get_device("777")
    assert sorted(e.value.ids) == ids
    r = rs_discover("get", "777", endpoint=ep)
    assert r.returncode == 1 and all(i in r.stderr for i in ids), r.stderr
    r = rs_discover("get", "no-such-camera", endpoint=ep)
    assert r.returncode == 1 and "no device 'no-such-camera'" in r.stderr


def test_list_json_is_the_apis_answer(daemon, realdds_server, domain):
    d = daemon([domain])
    realdds_server(domain, [device_info(1)], name="json-server")
    wait_for(lambda: len(d.device_ids()) == 1, 20, what="the device")
    r = rs_discover("list", "--json", endpoint="unix:" + d.socket)
    assert r.returncode == 0, r.stderr
    printed = json.loads(r.stdout)
    api = d.get_json("/v1/devices")
    assert printed["generation"] == api["generation"]
    assert printed == api | {"devices": [x | {"last-seen": y["last-seen"]}
                                         for x, y in zip(api["devices"], printed["devices"])]}


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to run as another user")
def test_default_socket_of_a_user_without_runtime_dir_is_found_by_both_clients(domain, tmp_path):
    """A non-root user without XDG_RUNTIME_DIR (su, cron, a container): the daemon and both
    clients, given no socket, meet at the same path."""
    user = pwd.getpwnam("nobody")
    sock = f"/tmp/rs-discoveryd-{user.pw_uid}.sock"
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_RUNTIME_DIR", "RUNTIME_DIRECTORY",
                                                               "RS_DISCOVERY_ENDPOINT")}
    as_user = ["setpriv", f"--reuid={user.pw_uid}", f"--regid={user.pw_gid}", "--clear-groups", "--"]
    # Readable by that user (pytest's tmp_path is root's alone): an empty config, so the
    # machine's /etc/rs-discoveryd/config.json does not reach in.
    fd, config = tempfile.mkstemp(prefix="rsd-contract-", suffix=".json", dir="/tmp")
    os.write(fd, b"{}")
    os.close(fd)
    os.chmod(config, 0o644)
    daemon = subprocess.Popen(as_user + [DAEMON, "--config", config, "--domain", str(domain), "--http", "off",
                                         "--no-usb"], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        wait_for(lambda: os.path.exists(sock) or daemon.poll() is not None, 15, what="the daemon's socket")
        assert daemon.poll() is None, daemon.stdout.read().decode()
        r = subprocess.run(as_user + [CLI, "health"], env=env, capture_output=True, text=True, timeout=30)
        assert r.returncode == 0, r.stderr
        pyenv = dict(env, PYTHONPATH=os.path.join(SOURCE, "client", "python", "src"))
        r = subprocess.run(as_user + ["/usr/bin/python3", "-c",  # the system one: any user may run it
                                      "import rsdiscovery; c = rsdiscovery.Client(); "
                                      "print(c.endpoint); print(c.health()['status'])"],
                           env=pyenv, capture_output=True, text=True, timeout=30)
        assert r.returncode == 0, r.stderr
        assert r.stdout.split() == ["unix:" + sock, "ok"]
    finally:
        daemon.terminate()
        daemon.wait(10)
        os.unlink(config)


def test_stream_messages_and_errors_validate_against_the_spec(daemon, domain):
    sys.path.insert(0, os.path.join(SOURCE, "tests", "api"))
    from api_util import SSEStream, schema_validator, validate_response

    d = daemon([domain])
    hello = SSEStream(d.socket)
    msg = hello.next()
    assert msg["event"] == "hello"
    schema_validator("#/components/schemas/Hello").validate(json.loads(msg["data"]))
    hello.conn.close()
    resync = SSEStream(d.socket, headers={"Last-Event-ID": "not-ours"})
    msg = resync.next()
    assert msg["event"] == "resync"
    schema_validator("#/components/schemas/Resync").validate(json.loads(msg["data"]))
    resync.conn.close()
    for path, route in (("/healthz?x=1", "/healthz"), ("/v1/devices/a?x=1", "/v1/devices/{id}"),
                        ("/v1/domains?x=1", "/v1/domains")):
        status, _, body = d.request(path)
        assert status == 400
        validate_response(route, 400, json.loads(body))
