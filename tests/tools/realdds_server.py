#!/usr/bin/env python3
"""A realdds camera server driven over stdin, for tests.

It runs librealsense's own realdds (pyrealsense2.pyrealdds, on Fast DDS), so the
daemon sees exactly what a networked RealSense camera sends. One participant,
any number of devices. Commands, one JSON object per line on stdin; each is
answered with one JSON line on stdout ({"ok": true} or {"ok": false, "error": ...}):

  {"cmd": "add", "info": {...device-info...}, "spec": {...}}
                                                new device_server (streams etc. of `spec`,
                                                see make_server), broadcasts info
  {"cmd": "broadcast", "info": {...}}           re-broadcast a changed device-info
  {"cmd": "disconnect", "topic-root": "..."}    broadcast_disconnect ('stopping')
  {"cmd": "remove", "topic-root": "..."}        destroy the device_server (writer goes)
  {"cmd": "quit"}                               exit normally

`spec` (and --spec for the --device devices) is a spec object or the name of one of SPECS:
"d555" is a camera librealsense takes for one (product line D500; Depth z16, Infrared 1 y8,
Color rgb) that publishes images. A spec with "images": true streams: each video stream
starts when its first reader matches (at the profile the last `open-streams` control
asked for, else its default) and publishes blank frames at the profile's rate, stamped
with the server's clock, until its last reader goes; `open-streams` is answered ok, and so
is librealsense's `hwm` (with no data).
"""
import argparse
import gc
import json
import sys
import threading
import time

import pyrealsense2.pyrealdds as dds


DEFAULT_STREAMS = {"streams": [{"kind": "color", "name": "Color", "sensor": "RGB Camera",
                                 "profiles": [[30, "rgb", 640, 480]], "default": 0,
                                 "options": [["Backlight Compensation", 0, 0, 1, 1, 0, "desc"]]}]}

# A camera as librealsense expects one (rsdiscovery's open tests and bench): with product line
# D400 and no depth it refuses it ("Advanced mode expects camera to have a depth sensor").
D555_STREAMS = [
    {"kind": "depth", "name": "Depth", "sensor": "Stereo Module",
     "profiles": [[30, "z16", 640, 480], [30, "z16", 1280, 720]], "default": 0,
     "options": [["Exposure", 8500, 1, 165000, 1, 8500, "Depth Exposure (usec)"]]},
    {"kind": "ir", "name": "Infrared 1", "sensor": "Stereo Module",
     "profiles": [[30, "y8", 640, 480], [30, "y8", 1280, 720]], "default": 0, "options": []},
    {"kind": "color", "name": "Color", "sensor": "RGB Camera",
     "profiles": [[30, "rgb", 640, 480], [30, "rgb", 1280, 720]], "default": 0,
     "options": [["Backlight Compensation", 0, 0, 1, 1, 0, "Enable / disable backlight compensation"]]},
]
SPECS = {"d555": {"streams": D555_STREAMS, "images": True,
                  "device-options": [["Laser Power", 150, 0, 360, 30, 150, "Manual laser power in mw"]],
                  "extrinsics": [["Depth", "Color", [1, 0, 0, 0, 1, 0, 0, 0, 1], [0.015, 0.0, 0.0]]]}}
BYTES_PER_PIXEL = {"rgb": 3, "rgb8": 3, "yuyv": 2, "yuv422_yuy2": 2, "uyvy": 2, "z16": 2, "16UC1": 2, "y16": 2,
                   "mono16": 2, "y8": 1, "mono8": 1}

STREAM_SERVERS = {"color": dds.color_stream_server, "depth": dds.depth_stream_server, "ir": dds.ir_stream_server,
                  "motion": dds.motion_stream_server}


def make_server(participant, info, spec=None):
    """A device_server for `info` with the streams, options and extrinsics of `spec`
    (what the daemon's Camera Discovery must report back):
      {"streams": [{"kind": "color|depth|ir|motion", "name", "sensor",
                    "profiles": [[fps, encoding, width, height]] (motion: [[fps]]),
                    "default": index, "options": [option JSON]}],
       "device-options": [option JSON], "extrinsics": [[from, to, [9 rotation], [3 translation]]]}"""
    spec = SPECS[spec] if isinstance(spec, str) else (spec or DEFAULT_STREAMS)
    streams = []
    for st in spec["streams"]:
        server = STREAM_SERVERS[st["kind"]](st["name"], st["sensor"])
        if st["kind"] == "motion":
            profiles = [dds.motion_stream_profile(p[0]) for p in st["profiles"]]
        else:
            profiles = [dds.video_stream_profile(p[0], getattr(dds.video_encoding, p[1]), p[2], p[3])
                        for p in st["profiles"]]
        server.init_profiles(profiles, st.get("default", 0))
        server.init_options([dds.option.from_json(o) for o in st.get("options", [])])
        if spec.get("images") and st["kind"] != "motion":
            server.on_readers_changed(_images.on_readers_changed)  # before init(), which opens the stream
        streams.append(server)
    extrinsics = {}
    for frm, to, rotation, translation in spec.get("extrinsics", []):
        e = dds.extrinsics()
        e.rotation, e.translation = tuple(rotation), tuple(translation)
        extrinsics[(frm, to)] = e
    server = dds.device_server(participant, info["topic-root"])
    if spec.get("images"):
        _images.streams[info["topic-root"]] = streams
        server.on_control(_images.on_control)
    server.init(streams, [dds.option.from_json(o) for o in spec.get("device-options", [])], extrinsics)
    server.broadcast(dds.message.device_info.from_json(info))
    return server


_REPLY_DELAY = 0.002


class Images:
    """Streams blank frames to whoever subscribes (realdds streams start on a reader match)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.asked = {}    # stream server -> [fps, encoding, width, height] from `open-streams`
        self.running = {}  # stream server -> threading.Event that stops its publisher
        # topic-root -> its stream servers: kept, so that realdds hands the callbacks these very
        # objects (pybind finds a live wrapper again), which key the two maps above
        self.streams = {}

    def on_control(self, server, control_id, control, reply):
        # realdds' client makes room for a reply only after its control is written
        # (dds-device-impl.cpp, write_control_message): a reply faster than that is dropped and
        # the client times out 2.5 s later. On loopback this server answered that fast about
        # one control in fifteen: it takes a little time, as a camera on a network would.
        time.sleep(_REPLY_DELAY)
        if control_id == "hwm":
            # librealsense's hardware-monitor commands (it sends two when it opens a D500):
            # answered, with no data. Answered as invalid controls (realdds' error reply), one
            # pipeline start or stop in about five waited 2.5 s for the reply to the control
            # after them, or timed out.
            reply["data"] = []
            return True
        if control_id != "open-streams":
            return False  # anything else is answered as an invalid control, as realdds does
        profiles = control.get("stream-profiles", {})
        with self.lock:
            for st in server.streams():
                if control.get("reset", True):
                    self.asked.pop(st, None)
                if st.name() in profiles:
                    self.asked[st] = profiles[st.name()]
        return True

    def on_readers_changed(self, stream, readers):
        with self.lock:
            if readers > 0 and stream not in self.running:
                fps, encoding, width, height = self.asked.get(stream) or stream.default_profile().to_json()
                stream.start_streaming(dds.video_encoding(encoding), width, height)
                stop = self.running[stream] = threading.Event()
                threading.Thread(target=self.publish, args=(stream, fps, encoding, width, height, stop),
                                 daemon=True).start()
            elif readers == 0 and stream in self.running:
                self._stop(stream)

    def _stop(self, stream):
        self.running.pop(stream).set()
        try:
            stream.stop_streaming()
        except Exception:
            pass

    def forget(self, topic_root):
        """Before a device server goes: its publishers end (they hold its streams)."""
        with self.lock:
            for st in self.streams.pop(topic_root, []):
                if st in self.running:
                    self._stop(st)
                self.asked.pop(st, None)

    @staticmethod
    def publish(stream, fps, encoding, width, height, stop):
        image = dds.message.image()
        image.width, image.height = width, height
        image.data = [0] * (width * height * BYTES_PER_PIXEL.get(encoding, 2))  # made once: pybind takes a list
        period, t = 1.0 / fps, time.monotonic()
        while not stop.is_set():
            image.timestamp = dds.now()
            try:
                stream.publish_image(image)
            except Exception:  # stopped between the check and the write
                break
            t += period
            stop.wait(max(0.0, t - time.monotonic()))


_images = Images()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--name", default="test-server")
    ap.add_argument("--device", action="append", default=[], help="device-info JSON")
    ap.add_argument("--spec", default=None, help="the --device devices' spec: a name of SPECS, or JSON")
    args = ap.parse_args()
    spec = None if args.spec is None else SPECS.get(args.spec) or json.loads(args.spec)

    participant = dds.participant()
    participant.init(args.domain, args.name)
    servers = {}
    for text in args.device:
        info = json.loads(text)
        servers[info["topic-root"]] = make_server(participant, info, spec)
    # "t": CLOCK_MONOTONIC right after the last broadcast, for latency benchmarks.
    print(json.dumps({"ok": True, "ready": True, "t": time.monotonic(), "guid": str(participant.guid())}),
          flush=True)

    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        try:
            msg = json.loads(line)
            cmd = msg["cmd"]
            if cmd == "add":
                servers[msg["info"]["topic-root"]] = make_server(participant, msg["info"], msg.get("spec"))
            elif cmd == "broadcast":
                servers[msg["info"]["topic-root"]].broadcast(dds.message.device_info.from_json(msg["info"]))
            elif cmd == "disconnect":
                servers[msg["topic-root"]].broadcast_disconnect()
            elif cmd == "remove":
                _images.forget(msg["topic-root"])
                del servers[msg["topic-root"]]
                gc.collect()
            elif cmd == "quit":
                print(json.dumps({"ok": True}), flush=True)
                break
            else:
                raise ValueError(f"unknown command {cmd}")
            print(json.dumps({"ok": True, "t": time.monotonic()}), flush=True)
        except Exception as e:  # reported to the test, which decides
            print(json.dumps({"ok": False, "error": repr(e)}), flush=True)
    servers.clear()
    gc.collect()


if __name__ == "__main__":
    main()
