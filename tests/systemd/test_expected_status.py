"""STATUS= for the expected cameras, from the real daemon to a test-owned NOTIFY_SOCKET:
"0 of 1 expected camera (missing: ...)" at start, "1 of 1" once a realdds server
announces it, missing again once it is gone."""
from conftest import device_info
from svc_util import notify_socket  # noqa: F401  (fixture)


def test_status_counts_the_expected_cameras(free_domain, daemon, realdds_server, notify_socket):
    cam = device_info(7)
    daemon([free_domain], extra=["--expect", f"front={cam['serial']}", "--expect", "wrist=realsense/D555_77"],
           env=notify_socket.env(), wait=False)
    base = f"devices on DDS domain {free_domain}; "
    missing_both = f"0 of 2 expected cameras (missing: front ({cam['serial']}), wrist (realsense/D555_77))"
    ready = notify_socket.wait(lambda m: m.get("READY") == "1", what="READY=1")
    assert ready["STATUS"] == "0 " + base + missing_both, ready
    server = realdds_server(free_domain, [cam])
    notify_socket.wait(lambda m: m.get("STATUS") == "1 device on DDS domain " + str(free_domain) +
                       "; 1 of 2 expected cameras (missing: wrist (realsense/D555_77))", what="front counted")
    server.command(cmd="disconnect", **{"topic-root": cam["topic-root"]})
    notify_socket.wait(lambda m: m.get("STATUS") == "0 " + base + missing_both, what="front missing again")
