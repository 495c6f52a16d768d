"""Bad device-info of every kind, written raw with Cyclone DDS (pyrealdds refuses
to send it): each is dropped, counted by reason and logged with the sender's
GUID, and the table and the daemon are untouched. Then CBOR that is valid."""
import json
import os
import subprocess
import time

import pytest

from conftest import EventStream, device_info, wait_for

RAW_WRITER = os.environ["RSD_RAW_WRITER"]
JSON, CBOR, CUSTOM = 0, 1, 2


class RawWriter:
    def __init__(self, domain):
        self.proc = subprocess.Popen([RAW_WRITER, str(domain)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     text=True)
        assert self.proc.stdout.readline().strip() == "matched"

    def write(self, fmt, data: bytes):
        self.proc.stdin.write(f"{fmt} {data.hex() or '-'}\n")
        self.proc.stdin.flush()
        assert self.proc.stdout.readline().strip() == "ok"

    def close(self):
        self.proc.stdin.close()
        self.proc.wait(10)


def rejected(d):
    return d.get_json("/v1/domains")["domains"][0]["rejected"]


def sync(d, writer):
    """A writer that was just matched may write before the daemon's Cyclone knows
    it, and that sample is lost for good. Write a harmless bad sample until the
    daemon has counted one: from then on it knows this writer."""
    for _ in range(50):
        before = rejected(d).get("empty", 0)
        writer.write(JSON, b"")
        deadline = time.monotonic() + 0.5
        while time.monotonic() < deadline:
            if rejected(d).get("empty", 0) > before:
                return
            time.sleep(0.02)
    pytest.fail("the daemon never received the raw writer's samples")


def cbor_text(s: bytes):
    assert len(s) < 24
    return bytes([0x60 + len(s)]) + s


def cbor_map(pairs):
    """A small CBOR encoder for flat maps of text (enough for device-info)."""
    out = bytes([0xA0 + len(pairs)])
    for k, v in pairs.items():
        out += cbor_text(k.encode()) + cbor_text(v.encode())
    return out


# An undefined data_format (say 7) is not here: Cyclone's writer refuses to send
# it and its reader drops it before the daemon sees it; the unit tests cover it.
BAD = [
    ("not-json", JSON, b"this is not json"),
    ("not-json", JSON, b'{"name": "x", "topic-root": '),
    ("not-object", JSON, b'["name", "topic-root"]'),
    ("not-object", JSON, b'"realsense/D455"'),
    ("missing-name", JSON, b'{"topic-root": "realsense/X_1"}'),
    ("missing-name", JSON, b'{"name": 42, "topic-root": "realsense/X_1"}'),
    ("missing-topic-root", JSON, b'{"name": "Intel RealSense D455"}'),
    ("missing-topic-root", JSON, b'{"name": "Intel RealSense D455", "topic-root": ["a"]}'),
    ("invalid-utf8", JSON, b'{"name": "Intel \xff\xfe", "topic-root": "realsense/X_2"}'),
    ("too-deep", JSON, b"[" * 2000 + b"]" * 2000),
    ("too-large", JSON, b'{"name": "x", "topic-root": "realsense/X_3", "pad": "' + b"a" * 4096 + b'"}'),
    ("bad-cbor", CBOR, b"\xff\x00\x13"),
    ("bad-cbor", CBOR, b"\xbf\x61"),  # truncated indefinite map
    ("too-deep", CBOR, b"\x81" * 3000 + b"\x00"),
    ("invalid-utf8", CBOR, bytes([0xA2]) + cbor_text(b"name") + bytes([0x62, 0xC3, 0x28]) +
     cbor_text(b"topic-root") + cbor_text(b"realsense/X_4")),
    ("custom-format", CUSTOM, b'{"name": "x", "topic-root": "realsense/X_5"}'),
]


def test_changed_device_info_updates_and_emits_changed(free_domain, daemon):
    """realdds sends one device-info per device_server, so a changed one (recovery
    toggling as the camera reboots into its recovery firmware) is written raw."""
    d = daemon([free_domain])
    writer = RawWriter(free_domain)
    sync(d, writer)
    info = device_info(1)
    writer.write(JSON, json.dumps(info).encode())
    wait_for(lambda: len(d.devices()) == 1, what="device listed")
    first_seen = d.devices()[0]["first-seen"]
    events = EventStream(d)
    writer.write(JSON, json.dumps(dict(info, recovery=True)).encode())
    ev = events.next()
    assert ev["event"] == "changed" and ev["json"]["recovery"] is True
    dev = d.devices()[0]
    assert dev["recovery"] is True and dev["first-seen"] == first_seen
    # The same message again is no news: no event, only last-seen moves.
    writer.write(JSON, json.dumps(dict(info, recovery=True)).encode())
    writer.write(JSON, json.dumps(info).encode())
    ev = events.next()
    assert ev["event"] == "changed" and ev["json"]["recovery"] is False
    events.close()
    writer.close()


def test_bad_input_is_dropped_counted_logged_and_harmless(free_domain, daemon, realdds_server):
    good = device_info(1)
    realdds_server(free_domain, [good])
    d = daemon([free_domain])
    wait_for(lambda: len(d.devices()) == 1, what="the real camera listed")
    writer = RawWriter(free_domain)
    sync(d, writer)
    expected = dict(rejected(d))
    for reason, fmt, payload in BAD:
        if reason == "too-large":
            payload = payload[:4096]  # the wire type's bound; Cyclone refuses more
        writer.write(fmt, payload)
        expected[reason] = expected.get(reason, 0) + 1
        wait_for(lambda: rejected(d).get(reason, 0) == expected[reason], timeout=5,
                 what=f"{reason} counted")
    assert rejected(d) == expected
    # Nothing bad entered the table; what it knew is still there, the daemon alive.
    assert [dev["serial"] for dev in d.devices()] == [good["serial"]]
    assert d.healthy()
    metrics = d.request("/metrics")[2].decode()
    assert f'reason="too-deep"' in metrics and f'reason="invalid-utf8"' in metrics
    # Logged with the sender's GUID, and rate-limited per sender and reason.
    log = d.log()
    assert "dropped a device-info from" in log and "not-json" in log
    assert log.count("bad-cbor (") <= 2

    # Valid CBOR device-info: taken like JSON.
    cbor_info = device_info(9, **{"topic-root": "realsense/D455_cbor"})
    writer.write(CBOR, cbor_map(cbor_info))
    wait_for(lambda: len(d.devices()) == 2, what="the CBOR device listed")
    dev = d.get_json(f"/v1/devices/dds-{free_domain}-realsense.D455_cbor")
    assert dev["serial"] == cbor_info["serial"] and dev["name"] == cbor_info["name"]
    # Its writer going away removes it, as for any device.
    writer.close()
    wait_for(lambda: len(d.devices()) == 1, what="CBOR device gone with its writer")
