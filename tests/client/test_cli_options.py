"""rs-discover's command line as a user of GNU tools expects it (issue 13), against the
real daemon and real realdds servers: getopt forms (bundled short options, attached
values, unique prefixes, repeated --domain), the filters by serial, name and address,
several ids for get, --format and --no-headers, watch lines that say what changed,
feedback on stderr, a 503 asked again after its Retry-After, endpoints as host:port,
and a bad RS_DISCOVERY_ENDPOINT named."""
import json
import re
import socket
import threading
import time

import os
import sys

import pytest
from client_util import DOMAIN_RANGE, SOURCE, WatchProcess, rs_discover
from conftest import UnixHTTPConnection, device_info, free_port, wait_for

sys.path.insert(0, os.path.join(SOURCE, "client", "python", "src"))
import rsdiscovery  # noqa: E402  (the package as shipped)


@pytest.fixture
def two_domains(daemon, realdds_server, domains):
    """A daemon on two domains with a camera on each: (daemon, endpoint, [domain, domain], [info, info])."""
    doms = [domains.take(*DOMAIN_RANGE), domains.take(*DOMAIN_RANGE)]
    infos = [device_info(11, name="Intel RealSense D455"), device_info(12, name="Intel RealSense D435")]
    for dom, info in zip(doms, infos):
        realdds_server(dom, [info], name=f"server-{dom}")
    d = daemon(doms)
    wait_for(lambda: len(d.devices()) == 2, 20, what="a camera on each domain")
    return d, "unix:" + d.socket, doms, infos


def ids(result):
    assert result.returncode == 0, result.stderr
    return sorted(result.stdout.split())


def test_getopt_forms_and_repeated_domains(two_domains):
    d, ep, (a, b), (first, second) = two_domains
    every = ids(rs_discover("list", "-q", endpoint=ep))
    assert len(every) == 2
    only_a = [x for x in every if x.startswith(f"dds-{a}-")]
    assert ids(rs_discover("list", "-q", f"-d{a}", endpoint=ep)) == only_a            # attached value
    assert ids(rs_discover("list", "-qd", str(a), endpoint=ep)) == only_a             # bundled, value after
    assert ids(rs_discover("list", "-q", f"--dom={a}", endpoint=ep)) == only_a        # unique prefix, =value
    assert ids(rs_discover("list", "-q", "-d", str(a), "--domain", str(b), endpoint=ep)) == every  # repeated: both
    assert ids(rs_discover("list", f"--domain={a}", "-q", "--", endpoint=ep)) == only_a
    wide = rs_discover("list", "-wH", endpoint=ep)                                    # bundled flags
    assert wide.returncode == 0 and not wide.stdout.startswith("NAME") and "dds-" in wide.stdout
    for version in (["-V"], ["--version"], ["list", "-V"], ["--vers"]):
        r = rs_discover(*version)
        assert r.returncode == 0 and re.fullmatch(r"rs-discover \d+\.\d+\.\d+\n", r.stdout), (version, r)
    r = rs_discover("list", "--s", "dds", endpoint=ep)  # --source, --serial: ambiguous
    assert r.returncode == 2 and "ambiguous" in r.stderr and "--serial" in r.stderr and "--source" in r.stderr
    r = rs_discover("list", "-d", endpoint=ep)
    assert r.returncode == 2 and "--domain needs a value" in r.stderr
    r = rs_discover("list", "-d300", endpoint=ep)
    assert r.returncode == 2 and "--domain wants a whole number from 0 to 232" in r.stderr


def test_filters_by_serial_name_and_address(two_domains):
    d, ep, (a, b), (first, second) = two_domains
    by_id = {x["serial"]: x["id"] for x in d.devices()}
    assert ids(rs_discover("list", "-q", "--serial", first["serial"], endpoint=ep)) == [by_id[first["serial"]]]
    assert ids(rs_discover("list", "-q", "-n", "d435", endpoint=ep)) == [by_id[second["serial"]]]
    address = d.devices()[0]["server"]["addresses"][0]
    assert len(ids(rs_discover("list", "-q", "-a", address, endpoint=ep))) == 2
    assert ids(rs_discover("list", "-q", "-a", "203.0.113.9", endpoint=ep)) == []
    # The daemon filters: the CLI's JSON is the API's answer for the same query.
    api = d.get_json(f"/v1/devices?name=D435")["devices"]
    assert json.loads(rs_discover("list", "--json", "--name", "D435", endpoint=ep).stdout)["devices"] == api
    # The Python package passes the same filters to the daemon.
    assert [x.raw for x in rsdiscovery.list_devices(name="d435", endpoint=ep)] == api
    assert [x.serial for x in rsdiscovery.list_devices(serial=first["serial"], endpoint=ep)] == [first["serial"]]
    assert len(rsdiscovery.list_devices(address=address, endpoint=ep)) == 2
    assert rsdiscovery.Client(ep).wait_for(timeout=5, count=1, name="D435").serial == second["serial"]
    with pytest.raises(ValueError):
        rsdiscovery.list_devices(serial="", endpoint=ep)


def test_get_several_format_and_no_headers(two_domains):
    d, ep, (a, b), (first, second) = two_domains
    r = rs_discover("get", first["serial"], second["topic-root"], "nope", endpoint=ep)
    assert r.returncode == 1 and "no device 'nope'" in r.stderr
    by_serial = {x["serial"]: x["id"] for x in d.devices()}
    assert [line.split()[1] for line in r.stdout.splitlines() if line.startswith("ID:")] == \
        [by_serial[first["serial"]], by_serial[second["serial"]]]  # in the order asked
    docs = json.loads(rs_discover("get", "--json", first["serial"], second["serial"], endpoint=ep).stdout)
    assert [x["serial"] for x in docs] == [first["serial"], second["serial"]]
    one = json.loads(rs_discover("get", "-j", first["serial"], endpoint=ep).stdout)
    assert one["serial"] == first["serial"]  # one ID: the document itself, as before

    r = rs_discover("list", "--format", "{serial}\\t{name}\\t{fw-version}\\t{state}\\t{{x}}", endpoint=ep)
    assert r.returncode == 0, r.stderr
    lines = sorted(r.stdout.splitlines())
    assert lines == sorted(f"{i['serial']}\t{i['name']}\t{i['fw-version']}\tok\t{{x}}" for i in (first, second))
    r = rs_discover("list", "--format", "{serial", endpoint=ep)
    assert r.returncode == 2 and "never closed" in r.stderr
    for command in (["list"], ["domains"], ["participants"]):
        # Tables show ages in whole seconds: a second can tick over between the two runs
        # (CI saw "0s" then "1s"), twice only if a run took a second.
        for _ in range(3):
            with_header = rs_discover(*command, endpoint=ep).stdout.splitlines()
            without = rs_discover(*command, "--no-headers", endpoint=ep).stdout.splitlines()
            if without == with_header[1:]:
                break
        assert without == with_header[1:], command


def test_watch_says_what_changed_and_reports_reconnects(daemon, realdds_server, domains, tmp_path):
    domain = domains.take(*DOMAIN_RANGE)
    info = device_info(13)
    server = realdds_server(domain, [info])
    sock = str(tmp_path / "watch.sock")
    d = daemon([domain], socket=sock)
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    # --initial: the camera there now comes first, so its line says the watch is live.
    watch = WatchProcess("unix:" + sock, "--initial")
    lines, errors = watch.lines, watch.errors
    wait_for(lambda: any(" added " in x for x in lines), 20, what="the watch's first line")
    # The daemon goes away and comes back: the watch says so on stderr, and goes on.
    d.stop()
    d2 = daemon([domain], socket=sock)
    wait_for(lambda: len(d2.devices()) == 1, 20, what="the camera in the restarted daemon")
    # A second server announces the camera with newer firmware: the device shows its
    # latest announcer, a `changed` event (realdds broadcasts once per server).
    realdds_server(domain, [dict(info, **{"fw-version": "5.16.1.0"})], name="second-server")
    wait_for(lambda: d2.devices()[0]["fw-version"] == "5.16.1.0", 20, what="the new firmware in the table")
    changed = wait_for(lambda: next((x for x in lines if " changed " in x and "5.16.1.0" in x), None), 20,
                       what="the watch's changed line")
    assert watch.interrupt() == 0, errors  # a user's Ctrl-C ends it cleanly
    err = "".join(errors)
    assert "fw-version 5.16.0.1 \u2192 5.16.1.0" in changed
    assert re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3} changed ", changed)
    assert "lost the daemon, reconnecting" in err and "connected again" in err
    assert err.index("lost the daemon") < err.index("connected again")  # nothing said of the first connection
    assert d2.healthy()


def test_a_busy_daemon_is_asked_again_after_retry_after(daemon, domains):
    domain = domains.take(*DOMAIN_RANGE)
    d = daemon([domain], extra=["--max-clients", "2"])

    def hold_a_slot():
        """A connection the daemon has taken as one of its clients (it answered a request on
        it and keeps it open), or None when it was refused: a connection closed just before
        can still hold its slot until the daemon has seen it go (CI saw the /metrics
        fixture's own request do that, and the test's 'busy' daemon then had a free slot)."""
        conn = UnixHTTPConnection(d.socket)
        try:
            conn.request("GET", "/v1/domains")
            r = conn.getresponse()
            r.read()
        except OSError:
            conn.close()
            return None
        if r.status == 200:
            return conn
        conn.close()
        return None

    held = []
    for _ in range(2):  # the daemon's two client slots, taken
        held.append(wait_for(hold_a_slot, 10, what="a client slot the daemon keeps"))
    third = socket.socket(socket.AF_UNIX)  # a third client is turned away at once
    third.settimeout(5)
    third.connect(d.socket)
    refusal = b""
    while chunk := third.recv(4096):  # the daemon answers before any request, then closes
        refusal += chunk
    third.close()
    assert refusal.startswith(b"HTTP/1.1 503 ") and b"\r\nRetry-After: 1\r\n" in refusal, refusal
    threading.Timer(1.5, lambda: held.pop().close()).start()
    t0 = time.monotonic()
    r = rs_discover("health", endpoint="unix:" + d.socket)
    assert r.returncode == 0, (r.stdout, r.stderr)  # not exit 4 on the 503
    assert time.monotonic() - t0 >= 1.0, (r.stdout, r.stderr)  # it waited as told
    assert "too many clients (limit 2); retry later; asking again in 1 s" in r.stderr, r.stderr  # and why
    for s in held:
        s.close()


def test_endpoints_as_host_port_and_a_bad_variable_named(daemon, domains):
    domain = domains.take(*DOMAIN_RANGE)
    d = daemon([domain])
    r = rs_discover("health", endpoint=f"127.0.0.1:{d.port}")
    assert r.returncode == 0 and f"http://127.0.0.1:{d.port}" in r.stdout, r.stderr
    r = rs_discover("health", env={"RS_DISCOVERY_ENDPOINT": "ftp://camera-pc"})
    assert r.returncode == 2 and r.stderr.startswith("rs-discover: RS_DISCOVERY_ENDPOINT: bad endpoint 'ftp://camera-pc'")
    free = free_port()  # nothing there: the bare host's default port is named in the error
    r = rs_discover("health", endpoint=f"127.0.0.1:{free}")
    assert r.returncode == 3 and f"http://127.0.0.1:{free}" in r.stderr
