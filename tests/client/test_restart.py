"""A daemon restart, as the clients see it: until the restarted daemon has heard from every
camera its answers say they are not complete, the clients wait for the complete table, and
running watches report only what really changed (issue 8, point 4).

The real daemon and real realdds servers; the C++ library (the CLI's pull-style watch and
the test driver's callback watch) and the Python package from the tree."""
import json
import os
import signal
import subprocess
import sys

import pytest
from client_util import CLI, DOMAIN_RANGE, DRIVER, SOURCE, rs_discover
from conftest import JsonLinesProcess, device_info, wait_for

sys.path.insert(0, os.path.join(SOURCE, "client", "python", "src"))
import rsdiscovery  # noqa: E402  (the package from the tree, as its own tests use it)


@pytest.fixture
def domain(domains):
    return domains.take(*DOMAIN_RANGE)


def cam(domain, n):
    return f"dds-{domain}-realsense.D455_1236222707{n:02d}"


def answers_at_once(d):
    """/v1/devices, /healthz and /v1/domains as soon as the daemon's socket answers."""
    def up():
        if d.proc.poll() is not None:
            pytest.fail(f"daemon exited with {d.proc.returncode}:\n{d.log()}")
        return d.healthy()

    wait_for(up, 15, interval=0.005, what="the daemon's API to answer")
    return d.get_json("/v1/devices"), d.get_json("/healthz"), d.get_json("/v1/domains")


class Lines(JsonLinesProcess):
    """A watch process printing one JSON object a line; `take()` drains what came."""

    def take(self):
        try:
            return self.drain()
        except AssertionError as e:
            raise AssertionError(f"{e}: {self.proc.stderr.read()}") from None


class PythonWatch:
    """The Python package's watch, read on its own thread into `events` (as dicts)."""

    def __init__(self, endpoint):
        self.watcher = rsdiscovery.Client(endpoint).watcher(initial=True)

    def take(self):
        out = []
        while True:
            e = self.watcher.next(timeout=0)
            if e is None:
                return out
            out.append({"event": e.type, "id": e.id, "synthetic": e.synthetic, "device": e.device})


def events_of(items):
    return [(i["event"], i["device"]["id"]) for i in items if "event" in i]


def test_watches_report_only_real_changes_across_a_restart(daemon, realdds_server, domain, tmp_path):
    sock = str(tmp_path / "api.sock")
    ep = "unix:" + sock

    def start(wait=True):  # the fixture stops every daemon at the end, whatever happens
        return daemon([domain], socket=sock, wait=wait)

    d = start()
    srv = realdds_server(domain, [device_info(41)])
    wait_for(lambda: d.device_ids() == [cam(domain, 41)], 20, what="the camera")

    cli = Lines([CLI, "--endpoint", ep, "watch", "--json", "--initial"], stderr=subprocess.PIPE)
    lib = Lines([DRIVER, "subscribe", ep], stdin=subprocess.PIPE, stderr=subprocess.PIPE)
    py = PythonWatch(ep)
    watches = {"rs-discover watch": cli, "library callback": lib, "python watch()": py}
    seen = {name: [] for name in watches}

    def caught_up(want):
        for name, w in watches.items():
            seen[name] += w.take()
        return all(events_of(seen[name])[-len(want):] == want for name in watches)

    try:
        # Every watch starts with the camera that is there.
        wait_for(lambda: caught_up([("added", cam(domain, 41))]), 20, what="every watch's initial camera")
        for name in watches:
            seen[name].clear()

        assert d.stop() == 0
        d2 = start(wait=False)
        listing, health, domains = answers_at_once(d2)
        assert listing["complete"] is False, listing  # the restarted daemon says it has not heard everyone yet
        assert health["status"] == "ok" and health["complete"] is False, health
        wait_for(lambda: d2.get_json("/v1/devices")["complete"], 20, what="the restarted daemon's complete table")
        assert d2.device_ids() == [cam(domain, 41)]

        # A real change after the restart: once every watch has reported it, anything the
        # restart made them report would have come before it (each stream is in order).
        srv.command(cmd="add", info=device_info(42))
        wait_for(lambda: caught_up([("added", cam(domain, 42))]), 30, what="every watch to report the new camera")
        for name in watches:
            assert events_of(seen[name]) == [("added", cam(domain, 42))], (name, seen[name])
        # The callback watch did go through the restart (not a stream that never broke).
        statuses = [i["status"] for i in seen["library callback"] if "status" in i]
        assert "disconnected" in statuses and statuses[-1] == "connected", statuses

        # A camera that really went while the daemon was down is still reported, once.
        assert d2.stop() == 0
        srv.command(cmd="remove", **{"topic-root": "realsense/D455_123622270741"})
        d3 = start(wait=False)
        wait_for(lambda: caught_up([("removed", cam(domain, 41))]), 30, what="every watch to report the removal")
        for name in watches:
            assert events_of(seen[name]) == [("added", cam(domain, 42)), ("removed", cam(domain, 41))], \
                (name, seen[name])
        assert d3.device_ids() == [cam(domain, 42)]
    finally:
        py.watcher.close()
        cli.proc.send_signal(signal.SIGTERM)
        lib.proc.stdin.close()
        assert cli.proc.wait(10) == 0
        assert lib.proc.wait(10) == 0


def test_answers_are_incomplete_right_after_start_then_complete(daemon, realdds_server, domain):
    realdds_server(domain, [device_info(43)])
    d = daemon([domain], wait=False)
    listing, health, domains = answers_at_once(d)
    assert listing["complete"] is False and health["complete"] is False and domains["complete"] is False
    assert [x["complete"] for x in domains["domains"]] == [False]
    status, _, body = d.request("/v1/devices/" + cam(domain, 43))
    if status == 404:  # not heard yet: the answer says it may still come
        assert json.loads(body)["complete"] is False

    # The first complete answer has the camera that was there all along.
    first_complete = wait_for(lambda: (lambda x: x if x["complete"] else None)(d.get_json("/v1/devices")), 20,
                              what="the complete table")
    assert [x["id"] for x in first_complete["devices"]] == [cam(domain, 43)]
    assert d.get_json("/healthz")["complete"] is True
    domains = d.get_json("/v1/domains")
    assert domains["complete"] is True and [x["complete"] for x in domains["domains"]] == [True]
    status, _, body = d.request("/v1/devices/dds-0-realsense.nothing")
    assert status == 404 and json.loads(body)["complete"] is True


def test_list_and_get_right_after_a_restart_show_the_camera(daemon, realdds_server, domain, tmp_path):
    sock = str(tmp_path / "api.sock")
    ep = "unix:" + sock
    d = daemon([domain], socket=sock)
    realdds_server(domain, [device_info(44)])
    wait_for(lambda: d.device_ids() == [cam(domain, 44)], 20, what="the camera")

    for how in ("cli list", "cli get", "python list", "python get", "python wait_for"):
        assert d.stop() == 0
        d = daemon([domain], socket=sock, wait=False)
        listing, health, _ = answers_at_once(d)
        assert listing["complete"] is False, listing  # right after the restart
        if how == "cli list":
            r = rs_discover("list", "-q", endpoint=ep)
            assert r.returncode == 0, r.stderr
            assert r.stdout.split() == [cam(domain, 44)], r.stdout
            assert "warning" not in r.stderr, r.stderr
        elif how == "cli get":
            r = rs_discover("get", "123622270744", endpoint=ep)
            assert r.returncode == 0, r.stderr
            assert f"ID:           {cam(domain, 44)}" in r.stdout
        elif how == "python list":
            assert [x.id for x in rsdiscovery.list_devices(endpoint=ep)] == [cam(domain, 44)]
        elif how == "python get":
            assert rsdiscovery.get_device(cam(domain, 44), endpoint=ep).serial == "123622270744"
        else:
            assert rsdiscovery.wait_for(lambda x: x.serial == "123622270744", timeout=20, endpoint=ep)


def test_not_waiting_is_said(daemon, domain):
    """--no-wait-complete answers at once, and an answer from an incomplete table says so."""
    d = daemon([domain], wait=False)
    answers_at_once(d)
    r = rs_discover("list", "--json", "--no-wait-complete", endpoint="unix:" + d.socket)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["devices"] == []
    # The first discovery takes seconds; this ran milliseconds after the first answer.
    assert doc["complete"] is False
    assert "has not finished its first discovery" in r.stderr, r.stderr
    r = rs_discover("list", "--no-wait-complete", "--complete-timeout", "1", endpoint="unix:" + d.socket)
    assert r.returncode == 2 and "exclude each other" in r.stderr
    # Python: complete_timeout=0 does not wait either.
    wait_for(lambda: d.get_json("/healthz")["complete"], 20, what="the complete table")
    assert rsdiscovery.list_devices(endpoint="unix:" + d.socket, complete_timeout=0) == []
    help_text = rs_discover("list", "--help").stdout
    assert "--no-wait-complete" in help_text and "--complete-timeout S" in help_text
