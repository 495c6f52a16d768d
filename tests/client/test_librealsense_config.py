"""What librealsense on this host will see: rs-discover doctor reads the user's
~/.realsense-config.json (HOME pointing at a test directory) and says why real
pyrealsense2's default rs.context().query_devices() finds none of the network cameras the
daemon lists; doctor --fix-librealsense writes the fix, after which that very call finds
the camera. Other domain, device-mask and a broken file are each found."""
import json
import os
import pwd
import subprocess
import sys
import textwrap

import pytest

from conftest import wait_for
from client_util import DOMAIN_RANGE, rs_discover

QUERY = textwrap.dedent("""
    import json, time
    import pyrealsense2 as rs
    t0 = time.monotonic()
    devices = rs.context().query_devices()
    print(json.dumps({"s": time.monotonic() - t0,
                      "serials": [d.get_info(rs.camera_info.serial_number) for d in devices]}))
""")


def query_devices(home):
    """librealsense's default query_devices() as a user's program runs it, with HOME=home."""
    r = subprocess.run([sys.executable, "-c", QUERY], capture_output=True, text=True, timeout=60,
                       env=dict(os.environ, HOME=str(home)))
    assert r.returncode == 0, r.stderr
    return json.loads([ln for ln in r.stdout.splitlines() if ln.startswith("{")][-1])


def doctor(endpoint, home, *args):
    return rs_discover("doctor", "--listen", "0", *args, endpoint=endpoint, env={"HOME": str(home)})


def librealsense_line(out):
    return next(ln for ln in out.stdout.splitlines() if ln.split()[1:2] == ["librealsense"])


@pytest.fixture
def camera(daemon, realdds_server, domains):
    domain = domains.take(*DOMAIN_RANGE)
    d = daemon([domain])
    server = realdds_server(domain, [], name="lrs-config-server")
    info = {"name": "Intel RealSense D555", "serial": "555000071", "product-line": "D500", "product-id": "0B56",
            "fw-version": "7.56.19829.840", "topic-root": "realsense/D555_555000071"}
    server.command(cmd="add", info=info, spec="d555")
    wait_for(lambda: d.devices(), 20, what="the camera listed")
    return d, domain, info


def test_no_config_then_fixed(camera, tmp_path):
    d, domain, info = camera
    home = tmp_path / "home"
    home.mkdir()
    before = query_devices(home)
    assert before["serials"] == [], before
    out = doctor(f"unix:{d.socket}", home)
    line = librealsense_line(out)
    # librealsense's default: said with its fix, as info (no file is no misconfiguration).
    assert line.startswith("info") and "will not see the 1 network camera" in line, line
    assert "there is no" in line and ".realsense-config.json" in line, line
    assert f'"domain": {domain}' in line and "--fix-librealsense" in line, line

    fixed = doctor(f"unix:{d.socket}", home, "--fix-librealsense")
    assert fixed.returncode == 0, fixed
    config = json.loads((home / ".realsense-config.json").read_text())
    assert config == {"context": {"dds": {"enabled": True, "domain": domain}}}, config
    after = query_devices(home)
    assert after["serials"] == [info["serial"]], after
    print(f"query_devices() before the fix: {before['s'] * 1000:.0f} ms, no camera; "
          f"after: {after['s'] * 1000:.0f} ms, {after['serials']}")
    assert "ok" in librealsense_line(doctor(f"unix:{d.socket}", home))


@pytest.mark.parametrize("case", ["domain", "mask", "broken", "disabled"])
def test_each_cause_is_found_and_fixed(camera, domains, tmp_path, case):
    d, domain, info = camera
    # Held for this test like its own: an unheld id may be another test's, cameras and all.
    elsewhere = domains.take(*DOMAIN_RANGE)
    home = tmp_path / "home"
    home.mkdir()
    path = home / ".realsense-config.json"
    other = {"realsense-viewer": {"context": {"dds": {"enabled": None}}}, "context": {"keep": 1}}
    texts = {
        "domain": json.dumps({**other, "context": {"keep": 1, "dds": {"enabled": True, "domain": elsewhere}}}),
        "mask": json.dumps({**other, "context": {"keep": 1, "dds": {"enabled": True, "domain": domain},
                                                 "device-mask": 2}}),
        "broken": '{"context": {"dds": {"enabled": true,}}}',
        "disabled": json.dumps(other),
    }
    path.write_text(texts[case])
    assert query_devices(home)["serials"] == []
    line = librealsense_line(doctor(f"unix:{d.socket}", home))
    want = {"domain": f"sets DDS domain {elsewhere}", "mask": "device-mask 0x2 leaves out product line D500",
            "broken": "does not parse", "disabled": "leaves DDS off"}[case]
    assert line.startswith("warn") and want in line, line

    assert doctor(f"unix:{d.socket}", home, "--fix-librealsense").returncode == 0
    assert (home / ".realsense-config.json.bak").read_text() == texts[case]  # the backup
    config = json.loads(path.read_text())
    if case != "broken":  # the rest kept
        assert config["realsense-viewer"] == other["realsense-viewer"] and config["context"]["keep"] == 1, config
    assert config["context"]["dds"] == {"enabled": True, "domain": domain}, config
    if case == "mask":
        assert config["context"]["device-mask"] == 2 | 0x20
    assert query_devices(home)["serials"] == [info["serial"]]


def test_under_sudo_both_the_invoking_users_and_roots_are_read(camera, tmp_path):
    if os.geteuid() != 0:
        pytest.fail("this suite runs as root (as ./dev.sh test does), like a program under sudo")
    d, _, _ = camera
    home = tmp_path / "home"
    home.mkdir()
    invoking = pwd.getpwnam("nobody")
    out = rs_discover("doctor", "--listen", "0", endpoint=f"unix:{d.socket}",
                      env={"HOME": str(home), "SUDO_USER": "nobody"})
    lines = [ln for ln in out.stdout.splitlines() if ln.split()[1:2] == ["librealsense"]]
    assert len(lines) == 2, out.stdout
    assert "programs of nobody" in lines[0] and f"{invoking.pw_dir}/.realsense-config.json" in lines[0], lines
    assert "programs of root" in lines[1] and str(home / ".realsense-config.json") in lines[1], lines
