"""Reload (SIGHUP, what `systemctl reload` sends): the config file is read again;
new domains are joined and removed ones left, devices of unchanged domains stay
untouched; an invalid file keeps the running configuration and says why in the
log and in STATUS=. RELOADING=1 and READY=1 bracket it."""
import signal
import time

from conftest import EventStream, device_info, wait_for
from svc_util import notify_socket, write_config  # noqa: F401  (fixture)


def joined(d):
    return sorted(x["domain"] for x in d.get_json("/v1/domains")["domains"])


def reload(d, notify):
    notify.drain()
    d.signal(signal.SIGHUP)
    notify.wait(lambda m: m.get("RELOADING") == "1" and "MONOTONIC_USEC" in m, what="RELOADING=1")
    return notify.wait(lambda m: m.get("READY") == "1", what="READY=1 after the reload")


def test_reload_joins_and_leaves_domains_keeping_unchanged_ones(tmp_path, domains, daemon, realdds_server,
                                                                 notify_socket):
    a, b = domains.take(60, 79), domains.take(60, 79)
    config = tmp_path / "config.json"
    write_config(config, domains=[a], usb=False)
    # No --domain flag: the file decides the domains (a flag would win over it).
    d = daemon([], extra=["--config", str(config)], env=notify_socket.env())
    realdds_server(a, [device_info(1)], name="server-a")
    realdds_server(b, [device_info(2)], name="server-b")
    wait_for(lambda: len(d.devices()) == 1, what="domain a's device")
    kept = d.devices()[0]
    stream = EventStream(d)

    write_config(config, domains=[a, b], usb=False)
    ready = reload(d, notify_socket)
    # READY=1 came once the new domain reads, and says so.
    assert ready["STATUS"].endswith(f"on DDS domains {min(a, b)},{max(a, b)}"), ready
    assert joined(d) == sorted([a, b])
    assert all(x["state"] == "running" for x in d.get_json("/v1/domains")["domains"])
    added = stream.next(timeout=15)
    assert added["event"] == "added" and added["json"]["domain"] == b, added
    wait_for(lambda: len(d.devices()) == 2, what="both devices")
    # Domain a's device was never touched: same entry, first seen before the reload.
    assert next(x for x in d.devices() if x["domain"] == a)["first-seen"] == kept["first-seen"]

    write_config(config, domains=[b], usb=False)
    hup = time.monotonic()
    ready = reload(d, notify_socket)
    assert joined(d) == [b]
    removed = stream.next(timeout=10)
    print(f"\nreload (domain dropped) -> removed(domain-left): {removed['t'] - hup:.3f} s")
    assert removed["event"] == "removed" and removed["json"]["domain"] == a, removed
    assert removed["json"]["reason"] == "domain-left", removed
    assert [x["domain"] for x in d.devices()] == [b]
    assert ready["STATUS"] == f"1 device on DDS domain {b}", ready
    log = d.log()
    assert f"domain {a}: left (no longer configured)" in log
    assert f"joined domain(s) {b}" in log
    stream.close()


def test_invalid_config_keeps_the_running_one_and_says_why(tmp_path, domains, daemon, realdds_server,
                                                          notify_socket):
    a = domains.take(60, 79)
    config = tmp_path / "config.json"
    write_config(config, domains=[a], usb=False)
    d = daemon([], extra=["--config", str(config)], env=notify_socket.env())
    realdds_server(a, [device_info(3)])
    wait_for(lambda: len(d.devices()) == 1, what="device")

    config.write_text('{"domains": [1, 999]}')
    ready = reload(d, notify_socket)
    assert "reload failed, still running the previous configuration" in ready["STATUS"], ready
    assert "0 to 232" in ready["STATUS"]
    assert ready["STATUS"].startswith(f"1 device on DDS domain {a}")
    assert joined(d) == [a] and len(d.devices()) == 1
    assert f"error: reload failed, still running the previous configuration: {config}" in d.log()
    # Nothing was reloaded, and the log never says it was.
    assert "reloaded" not in d.log(), d.log()

    config.write_text("{not json")
    ready = reload(d, notify_socket)
    assert "not valid JSON" in ready["STATUS"]

    # Fixed again: the complaint goes away.
    write_config(config, domains=[a], usb=False, **{"log-level": "info"})
    ready = reload(d, notify_socket)
    assert ready["STATUS"] == f"1 device on DDS domain {a}", ready
    wait_for(lambda: f"notice: reloaded: 1 device on DDS domain {a}" in d.log(), what="the reloaded line")
    assert d.proc.poll() is None


def test_settings_that_need_a_restart_are_named(tmp_path, domains, daemon, notify_socket):
    a = domains.take(60, 79)
    config = tmp_path / "config.json"
    write_config(config, domains=[a], usb=False)
    d = daemon([], extra=["--config", str(config)], env=notify_socket.env())
    write_config(config, domains=[a], usb=False, **{"participant-name": "renamed"})
    reload(d, notify_socket)
    assert "reload: participant-name changed; that takes effect on restart" in d.log()
    assert joined(d) == [a]
