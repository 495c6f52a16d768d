"""Opening a camera the daemon lists (issue 22): rsdiscovery.realdds.open and first_frame,
rsdiscovery.librealsense.device, and the two examples, against the real daemon and real
realdds servers (tests/tools/realdds_server.py's "d555": a camera librealsense takes for one,
D500 product line with Depth z16, Infrared 1 y8 and Color rgb, that publishes images).

librealsense runs in processes of its own (a user's program, started fresh): pyrealdds and
librealsense participants in one process disturb each other (librealsense's own tests say so)."""
import json
import os
import subprocess
import sys
import textwrap
import time

import pytest
from client_util import DOMAIN_RANGE, SOURCE
from conftest import wait_for

PACKAGE_SRC = os.path.join(SOURCE, "client", "python", "src")
EXAMPLES = os.path.join(SOURCE, "client", "python", "examples")
sys.path.insert(0, PACKAGE_SRC)
import rsdiscovery  # noqa: E402  (the package as shipped)
import rsdiscovery.librealsense  # noqa: E402
import rsdiscovery.realdds  # noqa: E402


def d555(serial):
    return {"name": "Intel RealSense D555", "serial": serial, "product-line": "D500", "product-id": "0B56",
            "fw-version": "7.56.19829.840", "topic-root": f"realsense/D555_{serial}"}


class Camera:
    def __init__(self, daemon, server, domain, info):
        self.daemon, self.server, self.domain, self.info = daemon, server, domain, info
        self.endpoint = "unix:" + daemon.socket
        self.id = f"dds-{domain}-" + info["topic-root"].replace("/", ".")

    def device(self):
        return rsdiscovery.get_device(self.id, endpoint=self.endpoint)


@pytest.fixture
def camera(daemon, realdds_server, domains):
    """A D555-like realdds camera the daemon lists."""
    domain = domains.take(*DOMAIN_RANGE)
    d = daemon([domain])
    server = realdds_server(domain, [], name="open-test-server")
    info = d555("555000001")
    server.command(cmd="add", info=info, spec="d555")
    cam = Camera(d, server, domain, info)
    wait_for(lambda: cam.id in d.device_ids(), 20, what="the camera listed")
    return cam


def run_python(code, endpoint, timeout=60):
    """`code` in a fresh interpreter with the package from the tree; (CompletedProcess, last JSON line)."""
    env = dict(os.environ, PYTHONPATH=PACKAGE_SRC, RS_DISCOVERY_ENDPOINT=endpoint)
    r = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=timeout,
                       env=env)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("{")]
    return r, (json.loads(lines[-1]) if lines else None)


# ---- rsdiscovery.realdds ----------------------------------------------------------------

def test_realdds_open_gives_a_ready_device_by_device_id_and_serial(camera):
    cam = camera.device()
    t0 = time.monotonic()
    dev = rsdiscovery.realdds.open(cam, endpoint=camera.endpoint)
    took = time.monotonic() - t0
    assert dev.is_ready()
    assert [s.name() for s in dev.streams()] == ["Depth", "Infrared 1", "Color"]
    assert {s.name(): s.type_string() for s in dev.streams()} == {"Depth": "depth", "Infrared 1": "ir",
                                                                   "Color": "color"}
    assert [o.get_name() for o in dev.options()] == ["Laser Power"]
    depth = dev.streams()[0]
    assert depth.default_profile().to_json() == [30, "16UC1", 640, 480]
    assert len(depth.profiles()) == 2
    # The device-info the daemon kept, not the daemon's own fields.
    assert dev.device_info().topic_root == camera.info["topic-root"]
    assert dev.device_info().serial == camera.info["serial"]
    # Made on the participant kept for the camera's domain.
    assert str(dev.participant().guid()) == str(rsdiscovery.realdds.participant(camera.domain).guid())
    marks = rsdiscovery.realdds.last_open["marks"]
    assert set(marks) >= {"participant", "matched", "device", "ready"} and marks["ready"] <= took
    print(f"open ready in {took * 1000:.1f} ms: {rsdiscovery.realdds.last_open}")

    # By id, serial and topic-root: the daemon is asked; the kept participant serves again.
    for key in (camera.id, camera.info["serial"], camera.info["topic-root"]):
        again = rsdiscovery.realdds.open(key, endpoint=camera.endpoint)
        assert again.is_ready() and again.n_streams() == 3
        assert str(again.participant().guid()) == str(dev.participant().guid())
    # A participant of the caller's own.
    from pyrealsense2 import pyrealdds as dds
    mine = dds.participant()
    mine.init(camera.domain, "open-test-own")
    own = rsdiscovery.realdds.open(cam, participant=mine, endpoint=camera.endpoint)
    assert own.is_ready() and str(own.participant().guid()) == str(mine.guid())


def test_realdds_first_frame(camera):
    dev = rsdiscovery.realdds.open(camera.device(), endpoint=camera.endpoint)
    frame = rsdiscovery.realdds.first_frame(dev)
    assert (frame.stream, frame.width, frame.height, frame.encoding) == ("Depth", 640, 480, "16UC1")
    assert len(frame.data) == 640 * 480 * 2
    assert abs(frame.timestamp - time.time()) < 30  # the server's clock: this host's
    color = rsdiscovery.realdds.first_frame(dev, "Color")
    assert (color.width, color.height, color.encoding, len(color.data)) == (640, 480, "rgb8", 640 * 480 * 3)
    ir = rsdiscovery.realdds.first_frame(dev, "Infrared 1")
    assert (ir.encoding, len(ir.data)) == ("mono8", 640 * 480)
    with pytest.raises(ValueError, match="no video stream 'Gyro'"):
        rsdiscovery.realdds.first_frame(dev, "Gyro")


def test_realdds_open_errors(camera, realdds_server):
    ep = camera.endpoint
    with pytest.raises(rsdiscovery.NotFound):
        rsdiscovery.realdds.open("nobody-here", endpoint=ep)
    with pytest.raises(ValueError):
        rsdiscovery.realdds.open(camera.device(), endpoint=ep, timeout=0)
    with pytest.raises(ValueError):
        rsdiscovery.realdds.open({"serial": "123"}, endpoint=ep)
    usb = {"id": "usb-3-1.2", "name": "Intel RealSense D435", "serial": "123", "source": "usb", "sources": ["usb"],
           "recovery": False}
    with pytest.raises(rsdiscovery.NotANetworkCamera) as e:
        rsdiscovery.realdds.open(usb, endpoint=ep)
    assert "librealsense" in str(e.value)
    assert isinstance(e.value, rsdiscovery.OpenError) and isinstance(e.value, rsdiscovery.RSDiscoveryError)

    # A camera that vanished: the daemon's document outlived it.
    info = d555("555000002")
    camera.server.command(cmd="add", info=info, spec="d555")
    gone_id = f"dds-{camera.domain}-realsense.D555_555000002"
    wait_for(lambda: gone_id in camera.daemon.device_ids(), 20, what="the second camera")
    doc = rsdiscovery.get_device(gone_id, endpoint=ep)
    camera.server.command(cmd="remove", **{"topic-root": info["topic-root"]})
    wait_for(lambda: gone_id not in camera.daemon.device_ids(), 20, what="the second camera removed")
    t0 = time.monotonic()
    with pytest.raises(rsdiscovery.DeviceGone):
        rsdiscovery.realdds.open(doc, endpoint=ep, timeout=10)
    assert time.monotonic() - t0 < 3  # told by the daemon, not by the timeout


PARTIAL_SERVER = """
import json, sys, time
import pyrealsense2.pyrealdds as dds
domain, root = int(sys.argv[1]), sys.argv[2]
p = dds.participant()
p.init(domain, "half-server")
info = dds.message.device_info.from_json({"name": "Intel RealSense D555", "serial": "555000009",
                                          "product-line": "D500", "topic-root": root})
broadcaster = dds.device_broadcaster(dds.publisher(p), info)
notification = dds.topic_writer(dds.message.flexible.create_topic(p, root + "/notification"))
notification.run(dds.topic_writer.qos(dds.reliability.reliable, dds.durability.volatile))
control = dds.topic_reader(dds.message.flexible.create_topic(p, root + "/control"))
control.run(dds.topic_reader.qos(dds.reliability.reliable, dds.durability.volatile))
print("ready", flush=True)
# The device header promises 3 streams; their headers never come.
while True:
    dds.message.flexible({"id": "device-header", "n-streams": 3, "extrinsics": []}).write_to(notification)
    time.sleep(0.1)
"""


def test_realdds_open_of_a_server_that_never_completes_its_initialization(daemon, domains):
    domain = domains.take(*DOMAIN_RANGE)
    d = daemon([domain])
    root = "realsense/D555_555000009"
    half = subprocess.Popen([sys.executable, "-c", PARTIAL_SERVER, str(domain), root], stdout=subprocess.PIPE,
                            text=True)
    try:
        assert "ready" in half.stdout.readline()
        cam_id = f"dds-{domain}-realsense.D555_555000009"
        wait_for(lambda: cam_id in d.device_ids(), 20, what="the half server's camera listed")
        t0 = time.monotonic()
        with pytest.raises(rsdiscovery.NotReady) as e:
            rsdiscovery.realdds.open(cam_id, endpoint="unix:" + d.socket, timeout=2)
        assert 1.9 < time.monotonic() - t0 < 4
        assert e.value.stage == "initialization"
        assert isinstance(e.value, TimeoutError) and "initialization set" in str(e.value)
    finally:
        half.kill()
        half.wait()


def test_realdds_without_pyrealsense2_is_a_typed_error(camera, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyrealsense2", None)  # what a missing package looks like to import
    with pytest.raises(rsdiscovery.Pyrealsense2Missing) as e:
        rsdiscovery.realdds.open(camera.device(), endpoint=camera.endpoint)
    assert isinstance(e.value, ImportError) and "rsdiscovery[realdds]" in str(e.value)
    with pytest.raises(rsdiscovery.Pyrealsense2Missing):
        rsdiscovery.librealsense.device(camera.device(), endpoint=camera.endpoint)


# ---- rsdiscovery.librealsense -------------------------------------------------------------

LIBREALSENSE_DEVICE = """
import json, sys, time
import pyrealsense2 as rs
import rsdiscovery, rsdiscovery.librealsense
key, first_frame = sys.argv[1], sys.argv[2] == "frame"
t0 = time.monotonic()
try:
    ctx, dev = rsdiscovery.librealsense.device(key, timeout=float(sys.argv[3]))
except rsdiscovery.OpenError as e:
    print(json.dumps({"error": type(e).__name__, "stage": getattr(e, "stage", None), "message": str(e),
                      "s": time.monotonic() - t0}))
    sys.exit(0)
out = {"s": time.monotonic() - t0, "name": dev.get_info(rs.camera_info.name),
       "serial": dev.get_info(rs.camera_info.serial_number), "port": dev.get_info(rs.camera_info.physical_port),
       "line": dev.get_info(rs.camera_info.product_line),
       "sensors": sorted(s.get_info(rs.camera_info.name) for s in dev.query_sensors())}
if first_frame:
    pipe = rs.pipeline(ctx)
    cfg = rs.config()
    cfg.enable_device(out["serial"])
    cfg.enable_stream(rs.stream.depth)
    pipe.start(cfg)
    f = pipe.wait_for_frames(5000).get_depth_frame()
    out.update(frame_s=time.monotonic() - t0, width=f.get_width(), height=f.get_height(), ts=f.get_timestamp())
    pipe.stop()
print(json.dumps(out))
"""


def test_librealsense_device_and_a_first_frame(camera):
    args = f"import sys; sys.argv[1:] = ['{camera.info['serial']}', 'frame', '10']\n"
    r, out = run_python(args + LIBREALSENSE_DEVICE, camera.endpoint)
    assert out and "error" not in out, r.stdout[-2000:] + r.stderr[-2000:]
    assert out["serial"] == camera.info["serial"] and out["port"] == camera.info["topic-root"]
    assert out["name"] == "Intel RealSense D555" and out["line"] == "D500"
    assert out["sensors"] == ["RGB Camera", "Stereo Module"]
    assert (out["width"], out["height"]) == (640, 480)
    assert abs(out["ts"] / 1000 - time.time()) < 30
    assert out["s"] < 2.9, f"no quicker than query_devices(): {out}"  # it waits 3 s at least
    print(f"librealsense.device {out['s'] * 1000:.0f} ms, first frame {out['frame_s'] * 1000:.0f} ms")


def test_librealsense_device_errors(camera):
    with pytest.raises(rsdiscovery.NotFound):
        rsdiscovery.librealsense.device("nobody-here", endpoint=camera.endpoint)
    with pytest.raises(ValueError):
        rsdiscovery.librealsense.device(camera.device(), endpoint=camera.endpoint, timeout=-1)
    # Vanished: listed when asked for, gone before librealsense could have it.
    info = d555("555000003")
    camera.server.command(cmd="add", info=info, spec="d555")
    gone_id = f"dds-{camera.domain}-realsense.D555_555000003"
    wait_for(lambda: gone_id in camera.daemon.device_ids(), 20, what="the second camera")
    doc = rsdiscovery.get_device(gone_id, endpoint=camera.endpoint)
    camera.server.command(cmd="remove", **{"topic-root": info["topic-root"]})
    wait_for(lambda: gone_id not in camera.daemon.device_ids(), 20, what="the second camera removed")
    code = ("import sys, json, rsdiscovery\n"
            f"sys.argv[1:] = [{json.dumps(json.dumps(doc.raw))}, 'no', '10']\n")
    r, out = run_python(code + LIBREALSENSE_DEVICE.replace("device(key,", "device(json.loads(key),"), camera.endpoint)
    assert out and out.get("error") == "DeviceGone", r.stdout[-2000:] + r.stderr[-2000:]
    assert out["s"] < 3


def test_the_camera_tool_is_a_camera_librealsense_opens(daemon, domains):
    # The README's camera without hardware: python -m rsdiscovery.camera_server, as a user runs it.
    domain = domains.take(*DOMAIN_RANGE)
    d = daemon([domain])
    tool = subprocess.Popen([sys.executable, "-m", "rsdiscovery.camera_server", "--domain", str(domain),
                             "--serial", "555000000042"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONPATH=PACKAGE_SRC))
    try:
        line = ""
        while not line.startswith("{"):  # the device-info it serves (realdds may log to stdout too)
            line = tool.stdout.readline()
            assert line, tool.stderr.read()
        info = json.loads(line)
        assert info["serial"] == "555000000042" and info["product-line"] == "D500"
        cam_id = f"dds-{domain}-realsense.D555_555000000042"
        wait_for(lambda: cam_id in d.device_ids(), 20, what="the tool's camera listed")
        args = "import sys; sys.argv[1:] = ['555000000042', 'frame', '10']\n"
        r, out = run_python(args + LIBREALSENSE_DEVICE, "unix:" + d.socket)
        assert out and "error" not in out, r.stdout[-2000:] + r.stderr[-2000:]
        assert out["name"] == "Intel RealSense D555" and out["serial"] == "555000000042"
        assert out["sensors"] == ["RGB Camera", "Stereo Module"] and (out["width"], out["height"]) == (640, 480)
    finally:
        tool.terminate()
        assert tool.wait(20) == 0, tool.stderr.read()
    wait_for(lambda: cam_id not in d.device_ids(), 20, what="the tool's camera removed")


def test_a_camera_librealsense_refuses_is_reported_with_its_reason(daemon, realdds_server, domains):
    # pyrealdds' own example: one colour stream, product line D400. librealsense sees it and
    # refuses to make a device of it; the error says why, in librealsense's words.
    domain = domains.take(*DOMAIN_RANGE)
    d = daemon([domain])
    info = {"name": "Intel RealSense D455", "serial": "455000000007", "product-line": "D400",
            "topic-root": "realsense/D455_455000000007"}
    realdds_server(domain, [info], name="colour-only-server")
    cam_id = f"dds-{domain}-realsense.D455_455000000007"
    wait_for(lambda: cam_id in d.device_ids(), 20, what="the colour-only camera listed")
    args = f"import sys; sys.argv[1:] = ['{cam_id}', 'no', '3']\n"
    r, out = run_python(args + LIBREALSENSE_DEVICE, "unix:" + d.socket)
    assert out and out["error"] == "NotReady" and out["stage"] == "listing", r.stdout[-2000:] + r.stderr[-2000:]
    assert out["message"].endswith("within 3 s; librealsense said: Advanced mode expects camera to have a "
                                   "depth sensor"), out["message"]


# ---- the examples -------------------------------------------------------------------------

def test_examples_print_the_first_frame(camera):
    env = dict(os.environ, PYTHONPATH=PACKAGE_SRC, RS_DISCOVERY_ENDPOINT=camera.endpoint)
    r = subprocess.run([sys.executable, os.path.join(EXAMPLES, "open_camera.py"), camera.info["serial"], "Color"],
                       capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    assert f"Intel RealSense D555 serial 555000001 on DDS domain {camera.domain}" in r.stdout
    assert "3 streams" in r.stdout
    assert "first frame of Color: 640x480 rgb8, 921600 bytes, timestamp " in r.stdout, r.stdout
    r = subprocess.run([sys.executable, os.path.join(EXAMPLES, "open_camera_librealsense.py")],
                       capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "sensors: Stereo Module, RGB Camera" in r.stdout
    assert "first frame of Depth: 640x480 format.z16, timestamp " in r.stdout, r.stdout
    r = subprocess.run([sys.executable, os.path.join(EXAMPLES, "open_camera.py"), "nobody-here"],
                       capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 1 and "no device 'nobody-here'" in r.stderr
    # The install line says how the package is installed (it is not on PyPI).
    for name in ("open_camera.py", "open_camera_librealsense.py"):
        with open(os.path.join(EXAMPLES, name)) as f:
            text = f.read()
        assert "pip install rsdiscovery" not in text and "python3-rsdiscovery" in text
        assert "pip install './client/python[realdds]'" in text
