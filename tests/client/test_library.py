"""The C++ library against the real daemon: the example program, the push-style watch
(callback) and the DeviceView through a daemon restart, and wait_for."""
import subprocess

import pytest
from client_util import DOMAIN_RANGE, DRIVER, EXAMPLE, fold
from conftest import JsonLinesProcess, device_info, wait_for


@pytest.fixture
def domain(domains):
    return domains.take(*DOMAIN_RANGE)


def test_example_lists_cameras(daemon, realdds_server, domain):
    d = daemon([domain])
    realdds_server(domain, [device_info(21)])
    wait_for(lambda: d.devices(), 20, what="the camera")
    r = subprocess.run([EXAMPLE, "unix:" + d.socket], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("1 camera(s) at unix:")
    assert f"serial 123622270721   dds domain {domain} at " in r.stdout
    r = subprocess.run([EXAMPLE, "unix:/nonexistent/api.sock"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 3 and "no socket at /nonexistent/api.sock" in r.stderr


def test_wait_for(daemon, realdds_server, domain):
    d = daemon([domain])
    ep = "unix:" + d.socket
    r = subprocess.run([DRIVER, "wait-for", ep, "nobody", "0.3"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 1
    waiter = subprocess.Popen([DRIVER, "wait-for", ep, "123622270722", "30"], stdout=subprocess.PIPE, text=True)
    realdds_server(domain, [device_info(21), device_info(22)])
    out, _ = waiter.communicate(timeout=40)
    assert waiter.returncode == 0
    assert out.strip() == f"dds-{domain}-realsense.D455_123622270722"


class Subscriber(JsonLinesProcess):
    """The library's callback watch (test driver) as a process; stdin closing stops it."""

    def __init__(self, endpoint):
        super().__init__([DRIVER, "subscribe", endpoint], stdin=subprocess.PIPE)


    def stop(self):
        self.proc.stdin.close()
        return self.proc.wait(10)


def test_callback_watch_survives_a_daemon_restart(realdds_server, daemon, domain, tmp_path):
    sock = str(tmp_path / "api.sock")

    def start():  # the fixture stops it at the end, whatever happens
        return daemon([domain], socket=sock)

    d = start()
    srv = realdds_server(domain, [device_info(31)])
    wait_for(lambda: len(d.devices()) == 1, 20, what="first device")
    sub = Subscriber("unix:" + sock)
    view, statuses, lines = {}, [], []

    def take():
        for item in sub.drain():
            lines.append(item)
            assert "error" not in item, lines
            if "event" in item:
                fold(view, item)
            elif "status" in item:
                statuses.append(item["status"])
        return True

    wait_for(lambda: take() and len(view) == 1, 10, what="the initial device")
    srv.command(cmd="add", info=device_info(32))
    wait_for(lambda: take() and len(view) == 2, 20, what="the second device")
    assert d.stop() == 0
    srv.command(cmd="disconnect", **{"topic-root": "realsense/D455_123622270731"})
    srv.command(cmd="remove", **{"topic-root": "realsense/D455_123622270731"})
    srv.command(cmd="add", info=device_info(33))
    d2 = start()
    want = sorted(f"dds-{domain}-realsense.D455_1236222707{n}" for n in (32, 33))
    wait_for(lambda: d2.device_ids() == want, 20, what="the restarted daemon's view")
    wait_for(lambda: take() and sorted(view) == want, 20, what="the callback's view to match it")
    assert "disconnected" in statuses and statuses[-1] == "connected", statuses
    assert sub.stop() == 0


class ViewProcess(JsonLinesProcess):
    """The library's DeviceView (test driver) as a process: ask("list") prints the view."""

    def __init__(self, endpoint):
        super().__init__([DRIVER, "view", endpoint], stdin=subprocess.PIPE)
        assert self.lines.get(timeout=30) == {"ready": True}

    def ask(self, command):
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()
        item = self.lines.get(timeout=30)
        assert item is not None, "the view driver ended"
        return item

    def ids(self):
        return sorted(d["id"] for d in self.ask("list")["devices"])


def without_times(devices):
    """Device documents by id, without the times a later sighting moves."""
    return {d["id"]: {k: v for k, v in d.items() if k not in ("last-seen", "first-seen")} for d in devices}


def test_device_view_follows_the_table_through_a_daemon_restart(realdds_server, daemon, domain, tmp_path):
    sock = str(tmp_path / "api.sock")
    d = daemon([domain], socket=sock)
    srv = realdds_server(domain, [device_info(41), device_info(42)])
    wait_for(lambda: len(d.devices()) == 2, 20, what="two cameras")
    view = ViewProcess("unix:" + sock)
    first = view.ask("list")
    assert first["connected"] is True
    assert without_times(first["devices"]) == without_times(d.devices())  # the daemon's own documents

    srv.command(cmd="add", info=device_info(43))
    srv.command(cmd="disconnect", **{"topic-root": "realsense/D455_123622270741"})
    want = [f"dds-{domain}-realsense.D455_1236222707{n}" for n in (42, 43)]
    wait_for(lambda: d.device_ids() == want, 20, what="the daemon's table: one added, one stopped")
    wait_for(lambda: view.ids() == want, 10, what="the view to follow it")

    assert d.stop() == 0
    wait_for(lambda: view.ask("list")["connected"] is False, 10, what="the view to see the daemon go")
    assert view.ids() == want  # the last view is kept meanwhile, not emptied
    srv.command(cmd="remove", **{"topic-root": "realsense/D455_123622270742"})
    srv.command(cmd="add", info=device_info(44))
    d2 = daemon([domain], socket=sock)
    want = [f"dds-{domain}-realsense.D455_1236222707{n}" for n in (43, 44)]
    wait_for(lambda: d2.device_ids() == want, 20, what="the restarted daemon's table")
    wait_for(lambda: view.ids() == want and view.ask("list")["connected"], 20,
             what="the view to follow the restarted daemon")
    assert without_times(view.ask("list")["devices"]) == without_times(d2.devices())

    assert view.ask("stop") == {"stopped": True}
    stopped = view.ask("list")
    assert stopped["error"] == "cancelled", stopped  # a stopped view is not passed off as current
    view.proc.stdin.close()
    assert view.proc.wait(10) == 0


def test_device_view_of_no_daemon_fails_at_once(tmp_path):
    r = subprocess.run([DRIVER, "view", f"unix:{tmp_path}/none.sock"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 3 and r.stderr.startswith("not_running 0: "), r.stderr
