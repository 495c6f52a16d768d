"""Camera Discovery in the clients (issue 12): `rs-discover describe`, the C++ library's
describe() and Python's describe_device(), each against the real daemon and a real
realdds server serving tests/camera_spec.py's camera; what they show is checked
against what the server declared, field by field."""
import json
import os
import subprocess
import sys

import pytest
from camera_spec import SPEC, TYPE, WIRE_FORMAT
from client_util import DOMAIN_RANGE, DRIVER, SOURCE, rs_discover
from conftest import device_info, wait_for

sys.path.insert(0, os.path.join(SOURCE, "client", "python", "src"))
import rsdiscovery  # noqa: E402  (the package as shipped)


@pytest.fixture
def camera(daemon, realdds_server, domains):
    """(daemon, device-info, id) of a realdds camera serving SPEC."""
    domain = domains.take(*DOMAIN_RANGE)
    info = device_info(40)
    server = realdds_server(domain, [])
    server.command(cmd="add", info=info, spec=SPEC)
    d = daemon([domain])
    cam_id = f"dds-{domain}-" + info["topic-root"].replace("/", ".")
    wait_for(lambda: d.device_ids() == [cam_id], 20, what="the camera listed")
    return d, info, cam_id


def wire_profile(kind, p):
    """A SPEC profile as the description has it: [fps, format, width, height]."""
    return [p[0], "", 0, 0] if kind == "motion" else [p[0], WIRE_FORMAT[p[1]], p[2], p[3]]


def test_library_describe_matches_the_servers_declaration(camera):
    d, info, cam_id = camera
    r = subprocess.run([DRIVER, "describe", "unix:" + d.socket, info["serial"]], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout)
    assert [s["name"] for s in got["streams"]] == [s["name"] for s in SPEC["streams"]]
    for s, want in zip(got["streams"], SPEC["streams"]):
        assert (s["type"], s["sensor"], s["metadata"]) == (TYPE[want["kind"]], want["sensor"], False)
        assert s["profiles"] == [wire_profile(want["kind"], p) for p in want["profiles"]]
        assert s["default"] == s["profiles"][want["default"]]
        assert s["options"] == [o[0] for o in want["options"]]
    assert got["device-options"] == [o[0] for o in SPEC["device-options"]]
    # Not there, and a USB-less daemon's unknown id: not_found (404), exit 3 from the driver.
    r = subprocess.run([DRIVER, "describe", "unix:" + d.socket, "nobody"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 3 and r.stderr.startswith("not_found 404"), r.stderr


def test_cli_describe_table_and_json(camera):
    d, info, cam_id = camera
    ep = "unix:" + d.socket
    r = rs_discover("describe", cam_id, endpoint=ep, timeout=60)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].split() == ["STREAM", "TYPE", "SENSOR", "PROFILE", "FPS", "DEFAULT"]
    text = r.stdout
    for want in SPEC["streams"]:
        assert want["name"] in text and want["sensor"] in text
        for i, p in enumerate(want["profiles"]):
            if want["kind"] == "motion":
                row = next(ln for ln in lines if ln.split()[-1:] in (["*"], [str(p[0])]) and f" {p[0]}" in ln)
            else:
                row = next(ln for ln in lines if f"{p[2]}x{p[3]} {WIRE_FORMAT[p[1]]}" in ln and f" {p[0]}" in ln)
            assert row.rstrip().endswith("*") == (i == want["default"]), row
    # Options: the device's and each stream's, with range and description.
    laser = next(ln for ln in lines if ln.startswith("Laser Power"))
    assert "device" in laser and "150 (0..360, step 30, default 150)" in laser and "Manual laser power" in laser
    exposure = next(ln for ln in lines if ln.startswith("Exposure"))
    assert "Depth" in exposure and "Depth Exposure (usec)" in exposure
    # --json is the daemon's document, unchanged.
    r = rs_discover("describe", "--json", info["serial"], endpoint=ep, timeout=60)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == d.get_json(f"/v1/devices/{cam_id}/description")
    # No such camera: exit 1 with the daemon's reason.
    r = rs_discover("describe", "nobody", endpoint=ep, timeout=60)
    assert r.returncode == 1 and "nobody" in r.stderr
    assert rs_discover("describe", endpoint=ep).returncode == 2


def test_python_describe_device(camera):
    d, info, cam_id = camera
    desc = rsdiscovery.describe_device(info["topic-root"], endpoint="unix:" + d.socket)
    assert desc == d.get_json(f"/v1/devices/{cam_id}/description")
    depth = next(s for s in desc["streams"] if s["name"] == "Depth")
    assert depth["default-profile"] == {"fps": 30, "format": "16UC1", "width": 848, "height": 480}
    with pytest.raises(rsdiscovery.NotFound):
        rsdiscovery.describe_device("nobody", endpoint="unix:" + d.socket)
    with pytest.raises(ValueError):
        rsdiscovery.describe_device("", endpoint="unix:" + d.socket)
