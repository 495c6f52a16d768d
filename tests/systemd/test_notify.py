"""sd_notify from the real daemon to a test-owned NOTIFY_SOCKET: READY=1 only once
every domain reads and the API listens, STATUS= follows the table, WATCHDOG=1
keeps coming, STOPPING=1 at the end."""
import signal

from conftest import device_info
from svc_util import notify_socket  # noqa: F401  (fixture)


def test_ready_only_when_every_domain_reads_and_the_api_listens(domains, daemon, notify_socket):
    a, b = domains.take(60, 79), domains.take(60, 79)
    d = daemon([a, b], env=notify_socket.env(), wait=False)
    first = notify_socket.wait(lambda m: "STATUS" in m, what="a first STATUS")
    assert first["STATUS"].startswith("starting:"), first
    assert "READY" not in first
    ready = notify_socket.wait(lambda m: m.get("READY") == "1", what="READY=1")
    # At READY=1 the API answers and every domain reads: nothing left to wait for.
    states = {x["domain"]: x["state"] for x in d.get_json("/v1/domains")["domains"]}
    assert states == {a: "running", b: "running"}, states
    assert d.request("/healthz", via="tcp")[0] == 200
    assert ready["STATUS"] == f"0 devices on DDS domains {min(a, b)},{max(a, b)}", ready
    # READY=1 was sent once, after a settle time (the reader follows ~1.7 s of discovery).
    assert notify_socket.all("READY") == ["1"]
    ready_at = next(t for t, m in notify_socket.messages if m.get("READY") == "1")
    assert ready_at - notify_socket.messages[0][0] > 1.0


def test_status_follows_devices_and_stopping_is_sent(free_domain, daemon, realdds_server, notify_socket):
    d = daemon([free_domain], env=notify_socket.env(), wait=False)
    notify_socket.wait(lambda m: m.get("READY") == "1", what="READY=1")
    server = realdds_server(free_domain, [device_info(1), device_info(2)])
    notify_socket.wait(lambda m: m.get("STATUS") == f"2 devices on DDS domain {free_domain}",
                       what="STATUS with 2 devices")
    server.quit()
    notify_socket.wait(lambda m: m.get("STATUS") == f"0 devices on DDS domain {free_domain}",
                       what="STATUS back to 0 devices")
    d.signal(signal.SIGTERM)
    assert d.proc.wait(5) == 0
    stopping = [m for _, m in notify_socket.messages if m.get("STOPPING") == "1"]
    assert stopping, notify_socket.messages[-3:]


def test_watchdog_is_fed_at_half_the_interval(free_domain, daemon, notify_socket):
    d = daemon([free_domain], env=notify_socket.env(watchdog_usec=1_000_000), wait=False)
    notify_socket.wait(lambda m: m.get("READY") == "1", what="READY=1")
    notify_socket.drain()
    times = []
    for _ in range(5):
        notify_socket.wait(lambda m: m.get("WATCHDOG") == "1", timeout=2.0, what="WATCHDOG=1")
        times.append(notify_socket.messages[-1][0])
    gaps = [b - a for a, b in zip(times, times[1:])]
    # Every ~0.5 s; what matters is that each comes inside the 1 s timeout, and
    # that pings are paced rather than sent in a burst.
    assert all(0.2 < g < 1.0 for g in gaps), gaps
    assert d.proc.poll() is None


def test_no_watchdog_for_another_pid(free_domain, daemon, notify_socket):
    env = notify_socket.env(watchdog_usec=500_000)
    env["WATCHDOG_PID"] = "1"  # the watchdog is someone else's: not ours to feed
    daemon([free_domain], env=env, wait=False)
    notify_socket.wait(lambda m: m.get("READY") == "1", what="READY=1")
    # Time enough for several 250 ms pings, if there were any.
    assert notify_socket.seen_within(lambda m: "WATCHDOG" in m, 1.5) is None
    assert "WATCHDOG" not in {k for _, m in notify_socket.messages for k in m}


def test_without_notify_socket_nothing_breaks(free_domain, daemon):
    d = daemon([free_domain])  # waits for the API and every domain reading
    assert d.get_json("/healthz", via="tcp") is not None
