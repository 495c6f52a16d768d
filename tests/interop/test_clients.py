"""Who uses each camera (/v1/devices/{id}/clients, the device's `in-use`, ?in-use=)
against real peers: the suite's d555 realdds server (tests/tools/realdds_server.py)
and realdds clients in processes of their own (tests/tools/realdds_client.py, as an
application using pyrealsense2.pyrealdds). A client that only makes a device is a
client with no streams, one that streams Depth is listed with it, two clients of
one camera are both listed and never counted for another camera; a clean exit
takes the client away within 1 s, a SIGKILL at its lease, each in one `changed`
event (timed from the client making its device, by the event's arrival; printed
with pytest -s)."""
import json
import os
import signal
import subprocess
import sys
import time

from conftest import TESTS_DIR, EventStream, wait_for

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "api"))
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "client"))
from api_util import validate_response  # noqa: E402
from client_util import WatchProcess  # noqa: E402

CLI = os.path.join(os.environ["RSD_BUILD_DIR"], "client", "rs-discover")
sys.path.insert(0, os.path.join(os.environ["RSD_SOURCE_DIR"], "client", "python", "src"))
import rsdiscovery  # noqa: E402  (the package as shipped)

LEASE = 3.0  # realdds announces a 3 s lease (realdds-wire.md)
# Within 1 s of making its device, and the time of one more heartbeat: a client
# made at once after its participant has its first endpoint announcements at
# times not taken by a peer that has not yet taken its participant's, and realdds
# (Fast DDS) sends them again at its 1 s SEDP heartbeat. Any DDS reader sees that
# second (bench/client_latency.py's observer does); the daemon's own share after
# DDS discovery is measured there.
LISTED_WITHIN = 1.0 + 0.25


def d555(serial):
    return {"name": "Intel RealSense D555", "serial": serial, "product-line": "D500", "product-id": "0B56",
            "topic-root": f"realsense/D555_{serial}"}


def served_d555(domain, daemon, realdds_server, serial):
    """A daemon on `domain` listing one d555 camera that the suite's realdds server
    serves: (daemon, its device-info, its id)."""
    d = daemon([domain])
    realdds_server(domain, [], name="d555-server").command(cmd="add", info=d555(serial), spec="d555")
    x = d555(serial)
    xid = f"dds-{domain}-" + x["topic-root"].replace("/", ".")
    wait_for(lambda: xid in d.device_ids(), 20, what="the camera")
    return d, x, xid


class Client:
    def __init__(self, domain, info, name, streams=()):
        args = [sys.executable, os.path.join(TESTS_DIR, "tools", "realdds_client.py"), "--domain", str(domain),
                "--name", name, "--info", json.dumps(info)]
        for s in streams:
            args += ["--stream", s]
        self.started = time.monotonic()
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.device_at = None  # when it made its dds.device (its first endpoints)
        while True:
            line = self.proc.stdout.readline()
            assert line, "realdds client exited"
            if line.startswith("{"):
                self.hello = json.loads(line)
                if "device" in self.hello:
                    self.device_at = self.hello["device"]
                    continue
                break
        self.ready = time.monotonic()
        assert self.hello["ready"], self.hello

    def quit(self):
        self.proc.stdin.write("quit\n")
        self.proc.stdin.flush()
        self.proc.wait(10)

    def kill(self):
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()


def clients(d, cam_id):
    body = d.get_json(f"/v1/devices/{cam_id}/clients")
    validate_response("/v1/devices/{id}/clients", 200, body)
    return body


def names(d, cam_id):
    return sorted(c["name"] for c in clients(d, cam_id)["clients"])


def device(d, cam_id):
    return d.get_json(f"/v1/devices/{cam_id}")


def test_clients_of_a_camera_come_stream_and_go(free_domain, daemon, realdds_server):
    d = daemon([free_domain])
    server = realdds_server(free_domain, [], name="d555-server")
    x, y = d555("555777"), d555("555888")
    server.command(cmd="add", info=x, spec="d555")
    server.command(cmd="add", info=y, spec="d555")
    xid, yid = (f"dds-{free_domain}-" + c["topic-root"].replace("/", ".") for c in (x, y))
    wait_for(lambda: set(d.device_ids()) >= {xid, yid}, 20, what="both cameras")
    assert clients(d, xid) == {"clients": [], "streams": {}}
    assert "in-use" not in device(d, xid)

    events = EventStream(d, query=f"?serial={x['serial']}")
    watch = WatchProcess("unix:" + d.socket, "--serial", x["serial"])

    def watched(text):
        return any(x["serial"] in ln and text in ln for ln in watch.lines)

    # A client that only makes a device: a client with no streams, listed within 1 s
    # of making its device (its first endpoints), in one `changed` event however many
    # endpoints it made.
    a = Client(free_domain, x, "my-robot-app")
    ev = events.next(types=("changed",))
    listed_a = ev["t"] - a.device_at
    print(f"\ndevice-only client listed {listed_a * 1000:.0f} ms after it made its device")
    assert ev["json"]["in-use"] == {"clients": 1, "streaming": []}
    assert listed_a < LISTED_WITHIN
    assert events.within(1.0) == []
    assert names(d, xid) == ["my-robot-app"]
    entry = clients(d, xid)["clients"][0]
    assert entry["streams"] == [] and entry["vendor"] == "fast-dds" and entry["addresses"]
    assert entry["guid"] != device(d, xid)["server"]["participant-guid"]
    assert clients(d, xid)["streams"] == {}
    assert device(d, xid)["in-use"] == {"clients": 1, "streaming": []}
    wait_for(lambda: watched("a client came (1 client, not streaming)"), what="rs-discover watch's line")
    # A client of X is never one of Y.
    assert clients(d, yid)["clients"] == [] and "in-use" not in device(d, yid)
    assert [dev["id"] for dev in d.devices("?in-use=true")] == [xid]
    assert yid in [dev["id"] for dev in d.devices("?in-use=false")]
    assert xid not in [dev["id"] for dev in d.devices("?in-use=false")]

    # The clients see it: rs-discover clients (table, --json), list's marker, Python.
    cli = [CLI, "--endpoint", "unix:" + d.socket]
    table = subprocess.run(cli + ["clients", x["serial"]], capture_output=True, text=True, timeout=10)
    assert table.returncode == 0, table.stderr
    assert "my-robot-app" in table.stdout and entry["guid"] in table.stdout and "streaming" not in table.stdout
    as_json = subprocess.run(cli + ["clients", "--json", xid], capture_output=True, text=True, timeout=10)
    assert json.loads(as_json.stdout) == clients(d, xid)
    listed = subprocess.run(cli + ["list"], capture_output=True, text=True, timeout=10).stdout
    assert [ln for ln in listed.splitlines() if x["serial"] in ln and "in use" in ln]
    assert not [ln for ln in listed.splitlines() if y["serial"] in ln and "in use" in ln]
    # The C++ library's filter (DeviceFilter::in_use), through the CLI built on it.
    in_use = subprocess.run(cli + ["list", "-q", "--in-use"], capture_output=True, text=True, timeout=10)
    assert (in_use.returncode, in_use.stdout.split()) == (0, [xid]), in_use.stderr
    free = subprocess.run(cli + ["list", "-q", "--free"], capture_output=True, text=True, timeout=10).stdout.split()
    assert yid in free and xid not in free, free
    both = subprocess.run(cli + ["list", "--in-use", "--free"], capture_output=True, text=True, timeout=10)
    assert both.returncode == 2 and "exclude each other" in both.stderr, both.stderr
    py = rsdiscovery.Client("unix:" + d.socket).clients(xid)
    assert [c.name for c in py.clients] == ["my-robot-app"] and py.clients[0].streams == () and py.streams == {}
    assert [dev.id for dev in rsdiscovery.Client("unix:" + d.socket).list_devices(in_use=True)] == [xid]
    assert xid not in [dev.id for dev in rsdiscovery.list_devices(endpoint="unix:" + d.socket, in_use=False)]

    # A second client, streaming Depth: listed within 1 s of making its device, then
    # streaming once it opens Depth (a second change: the reader comes after the
    # device is ready, which takes the server's answer).
    b = Client(free_domain, x, "depth-viewer", streams=["Depth"])
    ev = events.next(types=("changed",))
    listed_b = ev["t"] - b.device_at
    print(f"streaming client listed {listed_b * 1000:.0f} ms after it made its device")
    assert ev["json"]["in-use"]["clients"] == 2, ev["json"]
    assert listed_b < LISTED_WITHIN
    if ev["json"]["in-use"]["streaming"] == []:
        ev = events.next(types=("changed",))
    assert ev["json"]["in-use"] == {"clients": 2, "streaming": ["Depth"]}
    print(f"... streaming Depth {(ev['t'] - b.device_at) * 1000:.0f} ms after it made its device")
    assert events.within(1.0) == []
    assert names(d, xid) == ["depth-viewer", "my-robot-app"] and clients(d, xid)["streams"] == {"Depth": 1}
    by_name = {c["name"]: c for c in clients(d, xid)["clients"]}
    assert by_name["depth-viewer"]["streams"] == ["Depth"] and by_name["my-robot-app"]["streams"] == []
    assert device(d, xid)["in-use"] == {"clients": 2, "streaming": ["Depth"]}
    wait_for(lambda: watched("(2 clients, streaming Depth)"), what="watch: the streaming client came")
    table = subprocess.run(cli + ["clients", xid], capture_output=True, text=True, timeout=10).stdout
    assert "depth-viewer" in table and "streaming: Depth (1 reader)" in table
    listed = subprocess.run(cli + ["list"], capture_output=True, text=True, timeout=10).stdout
    assert [ln for ln in listed.splitlines() if x["serial"] in ln and "in use: Depth" in ln]
    py = rsdiscovery.Client("unix:" + d.socket).clients(xid)
    assert {c.name: c.streams for c in py.clients}["depth-viewer"] == ("Depth",) and py.streams == {"Depth": 1}
    assert clients(d, yid)["clients"] == []

    # A clean exit: gone within 1 s, in one change (its stream and its device go
    # together). SIGKILL: gone at its lease, in one change too.
    t0 = time.monotonic()
    b.quit()
    ev = events.next(types=("changed",))
    gone_b = ev["t"] - t0
    print(f"clean exit: gone {gone_b * 1000:.0f} ms after quit")
    assert ev["json"]["in-use"] == {"clients": 1, "streaming": []}, ev["json"]
    assert gone_b < 1.0
    assert events.within(1.0) == []
    assert names(d, xid) == ["my-robot-app"] and device(d, xid)["in-use"] == {"clients": 1, "streaming": []}
    wait_for(lambda: watched("a client left (1 client, not streaming)"), what="watch: the streaming client left")
    t0 = time.monotonic()
    a.kill()
    ev = events.next(types=("changed",), timeout=LEASE + 10)
    killed = ev["t"] - t0
    print(f"SIGKILL: gone {killed * 1000:.0f} ms after the kill (lease {LEASE} s)")
    assert "in-use" not in ev["json"], ev["json"]
    assert killed < LEASE + 1.0  # the lease runs from the client's last message, not from the kill
    assert events.within(1.0) == []
    assert names(d, xid) == [] and "in-use" not in device(d, xid)
    wait_for(lambda: watched("its last client left"), what="watch: the last client left")
    assert watch.interrupt() == 0, watch.errors
    # Camera Y had no client: watch follows X only, and no line about Y's clients.
    assert not [ln for ln in watch.lines if y["serial"] in ln], watch.lines
    events.close()


def event_id(ev):
    """The device id an event is about (a removal carries the device as last seen)."""
    doc = ev.get("json") or {}
    return doc.get("id") or (doc.get("device") or {}).get("id")


def test_the_in_use_filter_follows_clients_in_every_stream(free_domain, daemon, realdds_server):
    """/v1/events?in-use=true, `rs-discover watch --in-use`, Python's watch, watcher and
    wait_for with in_use=True: a camera enters the filtered stream (added) when a client
    comes and leaves it (removed) when its last client goes; ?in-use=false the other way."""
    import threading

    d, x, xid = served_d555(free_domain, daemon, realdds_server, "556222")
    endpoint = "unix:" + d.socket
    used, free = EventStream(d, query="?in-use=true"), EventStream(d, query="?in-use=false")
    watch = WatchProcess(endpoint, "--in-use")
    py = rsdiscovery.Client(endpoint)
    watcher = py.watcher(in_use=True)
    generator = rsdiscovery.watch(endpoint=endpoint, in_use=True)
    from_generator, waited = [], []
    threading.Thread(target=lambda: from_generator.extend([next(generator), next(generator)]), daemon=True).start()
    threading.Thread(target=lambda: waited.append(rsdiscovery.wait_for(endpoint=endpoint, in_use=True, timeout=30)),
                     daemon=True).start()
    assert py.wait_for(in_use=False, serial=x["serial"], timeout=10).id == xid
    wait_for(lambda: watcher.devices() == [] and watch.proc.poll() is None, what="the watches started")

    a = Client(free_domain, x, "my-robot-app")
    ev = used.next(types=("added", "changed", "removed"))
    assert (ev["event"], event_id(ev), ev["json"]["in-use"]) == ("added", xid, {"clients": 1, "streaming": []})
    ev = free.next(types=("added", "changed", "removed"))
    assert (ev["event"], event_id(ev)) == ("removed", xid)
    got = watcher.next(timeout=10)
    assert got is not None and (got.type, got.device.id) == ("added", xid), got
    assert got.device.in_use == rsdiscovery.InUse(clients=1, streaming=())
    wait_for(lambda: waited, what="wait_for(in_use=True)")
    assert waited[0].id == xid and waited[0].in_use.clients == 1
    wait_for(lambda: any(x["serial"] in ln for ln in watch.lines), what="rs-discover watch --in-use: the camera")
    came = [ln for ln in watch.lines if x["serial"] in ln]
    assert len(came) == 1 and " added " in came[0] and xid in came[0], came

    a.quit()
    ev = used.next(types=("added", "changed", "removed"))
    assert (ev["event"], event_id(ev)) == ("removed", xid)
    ev = free.next(types=("added", "changed", "removed"))
    assert (ev["event"], event_id(ev)) == ("added", xid) and "in-use" not in ev["json"]
    got = watcher.next(timeout=10)
    assert got is not None and (got.type, got.device.id) == ("removed", xid), got
    assert watcher.devices() == []
    wait_for(lambda: len(from_generator) == 2, what="watch(in_use=True): added, then removed")
    assert [(e.type, e.device.id) for e in from_generator] == [("added", xid), ("removed", xid)]
    wait_for(lambda: len([ln for ln in watch.lines if x["serial"] in ln]) > len(came),
             what="rs-discover watch --in-use: the camera gone")
    assert watch.interrupt() == 0, watch.errors
    went = [ln for ln in watch.lines if x["serial"] in ln][len(came):]
    assert len(went) == 1 and " removed " in went[0] and xid in went[0], went
    watcher.close()
    generator.close()
    used.close()
    free.close()


def test_clients_of_a_usb_or_unknown_device(free_domain, daemon):
    d = daemon([free_domain])
    status, _, body = d.request("/v1/devices/nobody/clients")
    assert status == 404, body
    status, _, body = d.request("/v1/devices?in-use=maybe")
    assert status == 400, body
    r = subprocess.run([CLI, "--endpoint", "unix:" + d.socket, "clients", "nobody"], capture_output=True, text=True,
                       timeout=10)
    assert r.returncode == 1 and "nobody" in r.stderr, (r.returncode, r.stderr)
    try:
        rsdiscovery.Client("unix:" + d.socket).clients("nobody")
        raise AssertionError("no NotFound")
    except rsdiscovery.NotFound:
        pass


def doctor(d, cam):
    """(exit status, the camera's own findings) of `rs-discover doctor CAM`."""
    r = subprocess.run([CLI, "--endpoint", "unix:" + d.socket, "doctor", "--json", "--listen", "0", cam],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode in (0, 1), (r.returncode, r.stdout, r.stderr)
    return r.returncode, [f for f in json.loads(r.stdout)["findings"] if f["topic"] in ("camera", "in-use")]


def test_doctor_names_the_client_streaming_a_camera(free_domain, daemon, realdds_server):
    """doctor ID: a free camera is ok; one a client has open but does not stream is
    worth knowing; one streamed to another client is the likely cause of a refused
    open-streams, and the doctor names that client and where it runs."""
    d, x, xid = served_d555(free_domain, daemon, realdds_server, "556111")
    _, found = doctor(d, x["serial"])
    assert [(f["verdict"], f["topic"]) for f in found] == [("ok", "camera"), ("ok", "in-use")], found
    assert "has no client: it is free" in found[1]["text"]

    a = Client(free_domain, x, "my-robot-app")
    wait_for(lambda: names(d, xid) == ["my-robot-app"], what="the device-only client")
    _, found = doctor(d, xid)
    assert [(f["verdict"], f["topic"]) for f in found] == [("ok", "camera"), ("info", "in-use")], found
    assert "1 client ('my-robot-app'" in found[1]["text"] and "none streaming" in found[1]["text"]

    b = Client(free_domain, x, "depth-viewer", streams=["Depth"])
    wait_for(lambda: clients(d, xid)["streams"] == {"Depth": 1}, what="Depth streamed")
    viewer = {c["name"]: c for c in clients(d, xid)["clients"]}["depth-viewer"]
    status, found = doctor(d, x["serial"])
    assert status == 1, found
    [warned] = [f for f in found if f["verdict"] == "warn"]
    assert warned["topic"] == "in-use", warned
    assert f"streams Depth to 'depth-viewer' at {', '.join(viewer['addresses'])}" in warned["text"], warned
    assert "a new open-streams asking other profiles of that stream is refused until it stops" in warned["text"]
    assert "my-robot-app" not in warned["text"]  # only the client that streams is to blame

    b.quit()
    wait_for(lambda: clients(d, xid)["streams"] == {}, what="Depth no longer streamed")
    _, found = doctor(d, xid)
    assert [(f["verdict"], f["topic"]) for f in found] == [("ok", "camera"), ("info", "in-use")], found
    a.quit()
    status, found = doctor(d, "nobody")
    assert status == 1 and found[0]["verdict"] == "fail" and "nobody" in found[0]["text"], found


LIBREALSENSE_STREAMING = """
import json, sys
import pyrealsense2 as rs
import rsdiscovery.librealsense
ctx, dev = rsdiscovery.librealsense.device(sys.argv[1], timeout=10)
pipe = rs.pipeline(ctx)
cfg = rs.config()
cfg.enable_device(sys.argv[1])
cfg.enable_stream(rs.stream.depth)
pipe.start(cfg)
pipe.wait_for_frames(5000)
print(json.dumps({"streaming": True}), flush=True)
sys.stdin.readline()
pipe.stop()
"""


def test_librealsense_streaming_through_a_pipeline_is_a_client(free_domain, daemon, realdds_server):
    d, x, xid = served_d555(free_domain, daemon, realdds_server, "555999")
    env = dict(os.environ, PYTHONPATH=os.path.join(os.environ["RSD_SOURCE_DIR"], "client", "python", "src"),
               RS_DISCOVERY_ENDPOINT="unix:" + d.socket)
    proc = subprocess.Popen([sys.executable, "-c", LIBREALSENSE_STREAMING, x["serial"]], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env=env)
    try:
        while not (line := proc.stdout.readline()).startswith("{"):
            assert line, "the librealsense program ended"
        assert json.loads(line) == {"streaming": True}
        wait_for(lambda: clients(d, xid)["streams"] == {"Depth": 1}, what="librealsense streaming Depth")
        found = clients(d, xid)["clients"]
        assert len(found) == 1 and found[0]["streams"] == ["Depth"] and found[0]["vendor"] == "fast-dds"
        assert device(d, xid)["in-use"] == {"clients": 1, "streaming": ["Depth"]}
        proc.stdin.write("quit\n")
        proc.stdin.flush()
        t0 = time.monotonic()
        assert proc.wait(20) == 0
        wait_for(lambda: clients(d, xid)["clients"] == [], timeout=LEASE + 10, what="librealsense gone")
        print(f"\nlibrealsense gone {(time.monotonic() - t0) * 1000:.0f} ms after its pipeline stopped")
        assert "in-use" not in device(d, xid)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_a_topic_name_too_long_is_counted_and_the_endpoint_kept(free_domain, daemon, cyclone_peer):
    """A peer naming its reader with a 300-byte topic: the endpoint is still counted
    for its participant, its topic is not kept, and the refusal shows in /v1/domains,
    /metrics and the Python client, while the daemon keeps answering."""
    d = daemon([free_domain])
    cyclone_peer(free_domain, "reader", topic="flood/" + "x" * 294)

    def refused():
        return d.get_json("/v1/domains")["domains"][0]["endpoints-refused"]
    wait_for(lambda: refused() == {"topic-name-too-long": 1}, what="the long topic name refused, once")
    validate_response("/v1/domains", 200, d.get_json("/v1/domains"))
    metrics = d.request("/metrics")[2].decode()
    assert f'rsd_endpoints_refused_total{{domain="{free_domain}",reason="topic-name-too-long"}} 1' in metrics
    assert f'rsd_endpoints_refused_total{{domain="{free_domain}",reason="participant-endpoint-limit"}} 0' in metrics
    dom = rsdiscovery.Client("unix:" + d.socket).domains()[0]
    assert dom.endpoints_refused == {"topic-name-too-long": 1}
    # Kept without its topic: the peer's participant still counts the reader.
    peers = [p for p in d.get_json("/v1/participants")["participants"] if p.get("endpoints", 0) >= 1]
    assert peers, d.get_json("/v1/participants")
    assert "endpoint of" in d.log() and "topic-name-too-long" in d.log()
    assert d.healthy()


class RosNode:
    """tests/tools/ros_node.py: a ROS 2 node's participant ("/"), its readers and
    its ros_discovery_info sample, from PyPI's Cyclone DDS."""

    def __init__(self, domain, node, topics, gid_size, other_node=None, about=None):
        args = [sys.executable, os.path.join(TESTS_DIR, "tools", "ros_node.py"), "--domain", str(domain),
                "--node", node, "--gid-size", str(gid_size)]
        for t in topics:
            args += ["--topic", t]
        if other_node:
            args += ["--other-node", other_node]
        if about:
            args += ["--about", about]
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline()
        assert line, "the ROS 2 node exited"
        self.hello = json.loads(line)

    def quit(self):
        self.proc.stdin.close()
        self.proc.wait(10)


def test_a_ros2_node_reading_a_stream_is_named_by_its_node(free_domain, daemon, realdds_server):
    """ROS 2 participants are all named "/": a client that is a ROS 2 node is named
    by the node owning its reader, from ros_discovery_info, for Humble's 24-octet
    GIDs and Iron's 16 alike; another node of the same process is not named, and a
    sample speaking for another participant is refused."""
    d, x, xid = served_d555(free_domain, daemon, realdds_server, "555999")
    depth = "rt/" + x["topic-root"] + "_Depth"

    for gid_size in (24, 16):
        node = RosNode(free_domain, "/robot/viewer", [depth], gid_size, other_node="/imu_filter")
        guid = node.hello["participant"]

        def entry():
            return next((c for c in clients(d, xid)["clients"] if c["guid"] == guid), None)
        wait_for(lambda: (entry() or {}).get("ros-nodes") == ["/robot/viewer"], what=f"the node named ({gid_size})")
        assert entry()["name"] == "/" and entry()["streams"] == ["Depth"]
        assert clients(d, xid)["streams"] == {"Depth": 1}
        table = subprocess.run([CLI, "--endpoint", "unix:" + d.socket, "clients", x["serial"]], capture_output=True, text=True)
        assert table.returncode == 0 and "/robot/viewer" in table.stdout and "/imu_filter" not in table.stdout, table
        typed = rsdiscovery.Client("unix:" + d.socket).clients(xid)
        assert [c.ros_nodes for c in typed.clients] == [("/robot/viewer",)]
        _, found = doctor(d, xid)
        assert any("streams Depth to '/robot/viewer'" in f["text"] for f in found), found
        node.quit()
        wait_for(lambda: entry() is None, what="the node gone with its participant")

    # A sample naming another participant than its writer's: its client stays unnamed.
    liar = RosNode(free_domain, "/robot/viewer", [depth], 16, about="0110abcd.00000001.00000002.000001c1")
    wait_for(lambda: any(c["guid"] == liar.hello["participant"] for c in clients(d, xid)["clients"]),
             what="the client listed")
    wait_for(lambda: "refused: about another participant" in d.log(), what="the refusal logged")
    assert [c["ros-nodes"] for c in clients(d, xid)["clients"]] == [[]]
    liar.quit()
    assert d.healthy()
