"""rs-discover against the real daemon and real realdds servers, read as a user reads it."""
import json
import os
import pty
import queue
import re
import select
import signal
import subprocess
import time

import pytest
from client_util import CLI, DOMAIN_RANGE, fold, rs_discover
from conftest import JsonLinesProcess, device_info, free_port, wait_for

ANSI = re.compile(r"\x1b\[[0-9;]*m")
COLUMNS = ["NAME", "SERIAL", "SOURCE", "DOMAIN/PORT", "ADDRESS", "STATE", "AGE"]


@pytest.fixture
def domain(domains):
    return domains.take(*DOMAIN_RANGE)


def table(stdout):
    """Rows of a table as dicts, cut at the header's column starts."""
    lines = stdout.splitlines()
    header = lines[0]
    names = header.split()
    starts = [header.index(n) for n in names]
    rows = []
    for line in lines[1:]:
        cells = [line[s:(starts[i + 1] if i + 1 < len(starts) else None)].strip() for i, s in enumerate(starts)]
        rows.append(dict(zip(names, cells)))
    return names, rows


def test_list_table_shows_what_the_whole_documents_say(daemon, realdds_server, domain):
    """The table asks the daemon for its columns' keys alone (?fields=); what it shows
    is what the whole documents say, and --json and --format still get whole ones."""
    d = daemon([domain])
    ep = "unix:" + d.socket
    realdds_server(domain, [device_info(1), device_info(2, **{"fw-version": "5.17.0.2"})], name="fields-cli")
    wait_for(lambda: len(d.device_ids()) == 2, timeout=20, what="2 devices listed")
    whole = {x["serial"]: x for x in d.devices()}
    r = rs_discover("list", "-w", endpoint=ep)
    assert r.returncode == 0, r.stderr
    # Split at runs of spaces (table() would find "ID" inside "PRODUCT-ID").
    lines = [re.split(r" {2,}", line.strip()) for line in r.stdout.splitlines()]
    names, rows = lines[0], [dict(zip(lines[0], cells)) for cells in lines[1:]]
    assert names == COLUMNS + ["PRODUCT-ID", "FW", "ID"]
    assert {row["SERIAL"] for row in rows} == set(whole)
    for row in rows:
        doc = whole[row["SERIAL"]]
        assert (row["NAME"], row["SOURCE"], row["DOMAIN/PORT"], row["STATE"]) == (doc["name"], "dds", str(domain), "ok")
        assert row["ADDRESS"] == ",".join(doc["server"]["addresses"])
        assert (row["PRODUCT-ID"], row["FW"], row["ID"]) == (doc["product-id"], doc["fw-version"], doc["id"])
        assert re.fullmatch(r"\d+[smhd]", row["AGE"])
    assert sorted(rs_discover("list", "-q", endpoint=ep).stdout.split()) == d.device_ids()
    listed = json.loads(rs_discover("list", "--json", endpoint=ep).stdout)["devices"]
    assert len(listed) == 2
    for x in listed:  # whole, as the API lists them (last-seen may have moved on)
        assert x == whole[x["serial"]] | {"last-seen": x["last-seen"]}
    r = rs_discover("list", "--format", "{serial} {topic-root} {server.participant-name}", endpoint=ep)
    assert sorted(r.stdout.splitlines()) == sorted(f"{k} {v['topic-root']} fields-cli" for k, v in whole.items())


def test_list_get_json_and_filters(daemon, realdds_server, domain):
    d = daemon([domain])
    ep = "unix:" + d.socket
    realdds_server(domain, [device_info(1), device_info(2, **{"multicast-ip": "239.255.0.9"})], name="cli-server")
    r = rs_discover("list", "--wait", "2", "--timeout", "20", endpoint=ep)
    assert r.returncode == 0, r.stderr
    assert not ANSI.search(r.stdout), "colour on a pipe"
    names, rows = table(r.stdout)
    assert names == COLUMNS
    assert sorted(row["SERIAL"] for row in rows) == ["123622270701", "123622270702"]
    for row in rows:
        assert row["NAME"] == "Intel RealSense D455"
        assert row["SOURCE"] == "dds"
        assert row["DOMAIN/PORT"] == str(domain)
        assert row["STATE"] == "ok"
        assert re.fullmatch(r"\d+[smhd]", row["AGE"])
        assert re.fullmatch(r"[0-9a-f.:,]+", row["ADDRESS"]), row["ADDRESS"]

    # --json is the API's document; -q the ids; -w adds columns.
    r = rs_discover("list", "--json", endpoint=ep)
    assert r.returncode == 0
    listed = json.loads(r.stdout)["devices"]
    assert sorted(x["id"] for x in listed) == d.device_ids()
    ids = rs_discover("list", "-q", endpoint=ep).stdout.split()
    assert sorted(ids) == d.device_ids()
    wide = rs_discover("list", "-w", endpoint=ep).stdout.splitlines()[0].split()
    assert wide == COLUMNS + ["PRODUCT-ID", "FW", "ID"]

    # get: by id, by serial; every field shown; --json.
    r = rs_discover("get", ids[0], endpoint=ep)
    assert r.returncode == 0, r.stderr
    assert f"ID:           {ids[0]}" in r.stdout
    assert f"Domain:       {domain}" in r.stdout
    r = rs_discover("get", "123622270702", endpoint=ep)
    assert r.returncode == 0
    assert "multicast-ip: 239.255.0.9" in r.stdout
    assert "Server:       cli-server" in r.stdout
    doc = json.loads(rs_discover("get", "--json", ids[0], endpoint=ep).stdout)
    assert doc == d.get_json("/v1/devices/" + ids[0]) | {"last-seen": doc["last-seen"]}
    r = rs_discover("get", "no-such-camera", endpoint=ep)
    assert r.returncode == 1
    assert "no device 'no-such-camera'" in r.stderr

    # Filters, and the HTTP endpoint given through the environment.
    assert rs_discover("list", "-q", "--domain", str(domain + 1), endpoint=ep).stdout == ""
    assert len(rs_discover("list", "-q", "--product-line", "D400", "--source", "dds", endpoint=ep).stdout.split()) == 2
    r = rs_discover("list", "-q", env={"RS_DISCOVERY_ENDPOINT": d.url})
    assert r.returncode == 0 and sorted(r.stdout.split()) == d.device_ids()


def test_domains_and_health(daemon, domain):
    d = daemon([domain])
    ep = "unix:" + d.socket
    r = rs_discover("domains", endpoint=ep)
    assert r.returncode == 0, r.stderr
    names, rows = table(r.stdout)
    assert names == ["DOMAIN", "STATE", "DEVICES", "ACCEPTED", "REJECTED", "PARTICIPANT"]
    assert rows[0]["DOMAIN"] == str(domain) and rows[0]["STATE"] == "running"
    assert json.loads(rs_discover("domains", "--json", endpoint=ep).stdout)["domains"][0]["domain"] == domain
    r = rs_discover("health", endpoint=d.url)
    assert r.returncode == 0
    assert r.stdout.startswith("ok: rs-discoveryd ") and "0 devices" in r.stdout
    assert json.loads(rs_discover("health", "--json", endpoint=ep).stdout)["status"] == "ok"


def test_wait_for_devices_and_timeout(daemon, realdds_server, domain):
    d = daemon([domain])
    ep = "unix:" + d.socket
    t0 = time.monotonic()
    r = rs_discover("list", "--wait", "1", "--timeout", "0.5", endpoint=ep)
    assert r.returncode == 1
    assert "timed out after 0.5s waiting for 1 device (0 present)" in r.stderr
    assert time.monotonic() - t0 < 5
    # A waiter started before the camera: it returns once the camera is there.
    waiter = subprocess.Popen([CLI, "--endpoint", ep, "list", "-q", "--wait", "1", "--timeout", "30"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    realdds_server(domain, [device_info(7)])
    out, err = waiter.communicate(timeout=40)
    assert waiter.returncode == 0, err
    assert out.split() == [f"dds-{domain}-realsense.D455_123622270707"]
    assert "waiting up to 30s for 1 device (0 present)" in err  # said on stderr while it waited


def test_daemon_not_running_and_permission(tmp_path):
    missing = str(tmp_path / "nothing.sock")
    r = rs_discover("list", endpoint="unix:" + missing)
    assert r.returncode == 3
    assert f"no socket at {missing}" in r.stderr and "is rs-discoveryd running?" in r.stderr
    # The default endpoint follows the daemon's rule; the message names it.
    r = rs_discover("list", env={"RUNTIME_DIRECTORY": str(tmp_path)})
    assert r.returncode == 3 and f"no socket at {tmp_path}/api.sock" in r.stderr
    r = rs_discover("health", endpoint=f"http://127.0.0.1:{free_port()}")
    assert r.returncode == 3 and "nothing listens on http://127.0.0.1:" in r.stderr
    r = rs_discover("list", endpoint="ftp://nowhere")
    assert r.returncode == 2 and "bad endpoint" in r.stderr


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to run a command as another user")
def test_permission_denied_is_named(daemon, domain, tmp_path):
    d = daemon([domain])
    os.chmod(tmp_path, 0o755)  # reachable by others; the socket itself is 0660 root
    r = subprocess.run(["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups", CLI, "--endpoint",
                        "unix:" + d.socket, "list"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 3, r.stderr
    assert f"permission denied on {d.socket}" in r.stderr


def test_usage_help_and_exit_codes():
    for cmd in ["list", "get", "watch", "domains", "health"]:
        r = rs_discover(cmd, "--help")
        assert r.returncode == 0 and r.stdout.startswith(f"Usage: rs-discover {cmd}"), cmd
        assert "Exit status: 0 ok, 1 not found or timed out, 2 usage error, 3 daemon unreachable" in r.stdout
    assert rs_discover("help", "watch").stdout.startswith("Usage: rs-discover watch")
    r = rs_discover("--help")
    assert r.returncode == 0 and "Commands:" in r.stdout
    assert rs_discover().returncode == 2
    r = rs_discover("frobnicate")
    assert r.returncode == 2 and "unknown command 'frobnicate'" in r.stderr
    r = rs_discover("list", "--bogus")
    assert r.returncode == 2 and "unknown option '--bogus'" in r.stderr
    assert rs_discover("list", "--domain", "999").returncode == 2
    assert rs_discover("get").returncode == 2
    assert re.fullmatch(r"rs-discover \d+\.\d+\.\d+\n", rs_discover("--version").stdout)


def run_on_tty(args, env=None):
    """Runs the CLI with stdout on a pseudo-terminal; returns (exit code, output)."""
    pid, fd = pty.fork()
    if pid == 0:
        os.environ.pop("NO_COLOR", None)
        os.environ["TERM"] = "xterm"
        os.environ.update(env or {})
        os.execv(CLI, [CLI] + args)
    out = b""
    while True:
        ready, _, _ = select.select([fd], [], [], 20)
        if not ready:
            break
        try:
            chunk = os.read(fd, 4096)
        except OSError:
            break
        if not chunk:
            break
        out += chunk
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status), out.decode()


def test_colour_only_on_a_terminal(daemon, domain):
    d = daemon([domain])
    ep = "unix:" + d.socket
    code, out = run_on_tty(["--endpoint", ep, "domains"])
    assert code == 0 and ANSI.search(out), out
    code, out = run_on_tty(["--endpoint", ep, "domains"], env={"NO_COLOR": "1"})
    assert code == 0 and not ANSI.search(out)
    assert not ANSI.search(rs_discover("domains", endpoint=ep).stdout)
    assert ANSI.search(rs_discover("domains", "--color", "always", endpoint=ep).stdout)


class Watcher(JsonLinesProcess):
    """`rs-discover watch --json` as a process; its lines read on a thread."""

    def __init__(self, endpoint, *extra):
        super().__init__([CLI, "--endpoint", endpoint, "watch", "--json", *extra], stderr=subprocess.PIPE)

    def next(self, timeout=20):
        try:
            item = self.lines.get(timeout=timeout)
        except queue.Empty:
            pytest.fail(f"no watch line within {timeout}s")
        assert item is not None, "watch ended: " + self.proc.stderr.read()
        return item

    def stop(self):
        """SIGTERM (SIGINT may be ignored when the test runs in a background job)."""
        self.proc.send_signal(signal.SIGTERM)
        code = self.proc.wait(10)
        self.stderr = self.proc.stderr.read()
        return code


def test_watch_lines_and_json(daemon, realdds_server, domain):
    d = daemon([domain])
    ep = "unix:" + d.socket
    human = subprocess.Popen([CLI, "--endpoint", ep, "watch", "--count", "2", "--timeout", "40"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    w = Watcher(ep)
    srv = realdds_server(domain, [device_info(3)])
    e = w.next()
    assert e["event"] == "added" and e["device"]["serial"] == "123622270703" and not e["synthetic"]
    assert isinstance(e["id"], int) and e["id"] > 0
    srv.command(cmd="disconnect", **{"topic-root": "realsense/D455_123622270703"})
    e2 = w.next()
    assert e2["event"] == "removed" and e2["id"] > e["id"]
    out, err = human.communicate(timeout=40)
    assert human.returncode == 0, err
    lines = out.splitlines()
    assert len(lines) == 2
    assert re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{3} added   dds-\d+-realsense\.D455_123622270703  Intel RealSense D455  "
                    rf"serial 123622270703  domain {domain}", lines[0]), lines[0]
    assert " removed dds-" in lines[1]
    assert w.stop() == 0, w.stderr  # a signal ends it cleanly


def test_watch_through_a_daemon_restart_loses_nothing(realdds_server, daemon, domain, tmp_path):
    sock = str(tmp_path / "api.sock")
    ep = "unix:" + sock

    def start():  # the fixture stops it at the end, whatever happens
        return daemon([domain], socket=sock)

    d = start()
    srv = realdds_server(domain, [device_info(11)])
    wait_for(lambda: len(d.devices()) == 1, 20, what="first device")
    w = Watcher(ep, "--initial")
    view = fold({}, w.next())
    assert sorted(view) == d.device_ids()
    srv.command(cmd="add", info=device_info(12))
    view = fold(view, w.next())
    assert len(view) == 2

    assert d.stop() == 0
    # While the daemon is down: one camera goes, another comes.
    srv.command(cmd="remove", **{"topic-root": "realsense/D455_123622270711"})
    srv.command(cmd="add", info=device_info(13))
    d2 = start()
    want = sorted(f"dds-{domain}-realsense.D455_1236222707{n}" for n in (12, 13))
    wait_for(lambda: d2.device_ids() == want, 20, what="the restarted daemon to see both cameras")
    events = []

    def caught_up():
        while True:
            try:
                item = w.lines.get_nowait()
            except queue.Empty:
                return sorted(view) == want
            assert item is not None, "watch ended: " + w.proc.stderr.read()
            events.append(item)
            fold(view, item)

    wait_for(caught_up, 20, what="the watch's view to match the restarted daemon")
    removed = [e for e in events if e["event"] == "removed"]
    assert any(e["device"]["serial"] == "123622270711" for e in removed), events
    assert any(e["event"] == "added" and e["device"]["serial"] == "123622270713" for e in events), events
    assert w.stop() == 0, w.stderr
