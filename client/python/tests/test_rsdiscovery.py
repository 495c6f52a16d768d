"""The rsdiscovery package against the real daemon and real realdds servers."""
import os
import time

import pytest
from conftest import DOMAIN, info, wait_until

import rsdiscovery


def test_installed_not_from_the_tree():
    assert "site-packages" in rsdiscovery.__file__, rsdiscovery.__file__


def test_endpoints(tmp_path, monkeypatch):
    assert rsdiscovery.Endpoint.parse("unix:///run/x.sock").path == "/run/x.sock"
    assert str(rsdiscovery.Endpoint.parse("http://127.0.0.1:8035")) == "http://127.0.0.1:8035"
    with pytest.raises(ValueError):
        rsdiscovery.Endpoint.parse("ftp://x")
    monkeypatch.delenv("RS_DISCOVERY_ENDPOINT", raising=False)
    monkeypatch.setenv("RUNTIME_DIRECTORY", str(tmp_path))
    assert rsdiscovery.Endpoint.from_environment().path == f"{tmp_path}/api.sock"
    with pytest.raises(rsdiscovery.DaemonNotRunning, match=f"no socket at {tmp_path}/api.sock"):
        rsdiscovery.list_devices()


def test_list_get_wait_domains_health(daemon_factory, server_factory):
    d = daemon_factory()
    ep = "unix:" + d.socket
    t0 = time.monotonic()
    assert rsdiscovery.wait_for(timeout=0.3, endpoint=ep) is None
    assert time.monotonic() - t0 < 3
    server_factory([info(1), info(2)])
    dev = rsdiscovery.wait_for(lambda x: x.get("serial") == "9876543202", timeout=20, endpoint=ep)
    assert dev is not None and dev["domain"] == DOMAIN
    assert rsdiscovery.wait_for(timeout=20, count=2, endpoint=ep) is not None
    devices = rsdiscovery.list_devices(endpoint=ep)
    assert sorted(x["serial"] for x in devices) == ["9876543201", "9876543202"]
    assert rsdiscovery.list_devices(domain=DOMAIN + 1, endpoint=ep) == []
    assert len(rsdiscovery.list_devices(product_line="D400", source="dds", endpoint=d.url)) == 2
    got = rsdiscovery.get_device(dev["id"], endpoint=ep)
    assert got["topic-root"] == "realsense/D455_9876543202" and got["server"]["addresses"]
    with pytest.raises(rsdiscovery.NotFound):
        rsdiscovery.get_device("nope", endpoint=ep)
    assert rsdiscovery.domains(endpoint=ep)[0]["domain"] == DOMAIN
    assert rsdiscovery.health(endpoint=ep)["status"] == "ok"


def test_watch_resumes_across_a_daemon_restart(daemon_factory, server_factory):
    d = daemon_factory()
    ep = "unix:" + d.socket
    srv = server_factory([info(11)])
    wait_until(lambda: rsdiscovery.list_devices(endpoint=ep), what="first device")
    client = rsdiscovery.Client(ep)
    view = {}
    seen = []

    def fold(e):
        seen.append(e)
        if e.type == "removed":
            view.pop(e.device["id"], None)
        else:
            view[e.device["id"]] = e.device

    with client.watcher(initial=True) as w:
        e = w.next(10)
        assert e.type == "added" and e.synthetic
        fold(e)
        srv.command(cmd="add", info=info(12))
        e = w.next(20)
        assert e.type == "added" and not e.synthetic and e.id > 0
        fold(e)
        d.stop()
        srv.command(cmd="remove", **{"topic-root": "realsense/D455_9876543211"})
        srv.command(cmd="add", info=info(13))
        d2 = daemon_factory()
        want = sorted(f"dds-{DOMAIN}-realsense.D455_98765432{n}" for n in (12, 13))
        wait_until(lambda: sorted(x["id"] for x in rsdiscovery.list_devices(endpoint=ep)) == want,
                   what="the restarted daemon's view")

        def caught_up():
            e = w.next(0.2)
            if e:
                fold(e)
            return sorted(view) == want

        wait_until(caught_up, what="the watch's view to match")
        assert any(e.type == "removed" and e.device["serial"] == "9876543211" for e in seen)
        assert w.last_event_id and w.last_event_id > seen[1].id
        d2.stop()

    # The generator form ends cleanly when closed.
    d3 = daemon_factory()
    gen = rsdiscovery.watch(initial=True, endpoint="unix:" + d3.socket)
    first = next(gen)
    assert first.type == "added"
    gen.close()
    d3.stop()


def test_daemon_gone_errors(tmp_path):
    with pytest.raises(rsdiscovery.DaemonNotRunning, match="no socket at"):
        rsdiscovery.list_devices(endpoint=f"unix:{tmp_path}/none.sock")
    with pytest.raises(rsdiscovery.DaemonNotRunning):
        rsdiscovery.watch(endpoint=f"unix:{tmp_path}/none.sock")
    assert issubclass(rsdiscovery.VersionMismatch, rsdiscovery.RSDiscoveryError)
