"""A RealSense network camera without hardware: a realdds camera server (librealsense's own
realdds, ``pyrealsense2.pyrealdds``) that librealsense lists and opens, and streams blank images.

    python -m rsdiscovery.camera_server --domain 0           # a D555-like camera, until Ctrl-C
    python -m rsdiscovery.camera_server --domain 0 --serial 555000000002

librealsense accepts a simulated camera only when it looks like one it knows: product line
``D500`` with Depth (z16), Infrared 1 (y8) and Color (rgb) streams, as :data:`SPECS` ``"d555"``
serves. With product line ``D400`` and no depth stream it refuses it ("Advanced mode expects
camera to have a depth sensor"); with no product line it does not list it at all.

:func:`make_server` is the library part: a ``pyrealdds.device_server`` for a device-info and a
spec of streams, options and extrinsics (the daemon's tests serve theirs with it).
Needs ``pyrealsense2`` 2.56 or later: ``pip install 'rsdiscovery[realdds]'``.
"""
from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
import time
from typing import Any, Dict, List, Mapping, Optional, Union

from ._open import Pyrealsense2Missing


def _pyrealdds() -> Any:
    try:
        import pyrealsense2.pyrealdds as dds  # type: ignore[import-not-found, import-untyped, unused-ignore]
    except ImportError as e:
        raise Pyrealsense2Missing("rsdiscovery.camera_server needs pyrealsense2 2.56 or later: "
                                  "pip install 'rsdiscovery[realdds]'", name="pyrealsense2") from e
    return dds


DEFAULT_STREAMS: Dict[str, Any] = {
    "streams": [{"kind": "color", "name": "Color", "sensor": "RGB Camera", "profiles": [[30, "rgb", 640, 480]],
                 "default": 0, "options": [["Backlight Compensation", 0, 0, 1, 1, 0, "desc"]]}]}

# A camera as librealsense expects one: with product line D400 and no depth it refuses it.
D555_STREAMS: List[Dict[str, Any]] = [
    {"kind": "depth", "name": "Depth", "sensor": "Stereo Module",
     "profiles": [[30, "z16", 640, 480], [30, "z16", 1280, 720]], "default": 0,
     "options": [["Exposure", 8500, 1, 165000, 1, 8500, "Depth Exposure (usec)"]]},
    {"kind": "ir", "name": "Infrared 1", "sensor": "Stereo Module",
     "profiles": [[30, "y8", 640, 480], [30, "y8", 1280, 720]], "default": 0, "options": []},
    {"kind": "color", "name": "Color", "sensor": "RGB Camera",
     "profiles": [[30, "rgb", 640, 480], [30, "rgb", 1280, 720]], "default": 0,
     "options": [["Backlight Compensation", 0, 0, 1, 1, 0, "Enable / disable backlight compensation"]]},
]
SPECS: Dict[str, Dict[str, Any]] = {
    "d555": {"streams": D555_STREAMS, "images": True,
             "device-options": [["Laser Power", 150, 0, 360, 30, 150, "Manual laser power in mw"]],
             "extrinsics": [["Depth", "Color", [1, 0, 0, 0, 1, 0, 0, 0, 1], [0.015, 0.0, 0.0]]]}}
BYTES_PER_PIXEL = {"rgb": 3, "rgb8": 3, "yuyv": 2, "yuv422_yuy2": 2, "uyvy": 2, "z16": 2, "16UC1": 2, "y16": 2,
                   "mono16": 2, "y8": 1, "mono8": 1}


def d555_info(serial: str = "555000000001") -> Dict[str, Any]:
    """The device-info of a D555 with this serial, as librealsense expects it."""
    return {"name": "Intel RealSense D555", "serial": serial, "product-line": "D500", "product-id": "0B56",
            "fw-version": "7.56.19829.840", "topic-root": f"realsense/D555_{serial}"}


def make_server(participant: Any, info: Mapping[str, Any], spec: Union[str, Mapping[str, Any], None] = None) -> Any:
    """A device_server for `info` with the streams, options and extrinsics of `spec`, a name
    of :data:`SPECS` or
      {"streams": [{"kind": "color|depth|ir|motion", "name", "sensor",
                    "profiles": [[fps, encoding, width, height]] (motion: [[fps]]),
                    "default": index, "options": [option JSON]}],
       "device-options": [option JSON], "extrinsics": [[from, to, [9 rotation], [3 translation]]],
       "images": true (streams blank frames to whoever subscribes)};
    then broadcasts `info`."""
    dds = _pyrealdds()
    spec = SPECS[spec] if isinstance(spec, str) else (spec or DEFAULT_STREAMS)
    makers = {"color": dds.color_stream_server, "depth": dds.depth_stream_server, "ir": dds.ir_stream_server,
              "motion": dds.motion_stream_server}
    streams = []
    for st in spec["streams"]:
        server = makers[st["kind"]](st["name"], st["sensor"])
        if st["kind"] == "motion":
            profiles = [dds.motion_stream_profile(p[0]) for p in st["profiles"]]
        else:
            profiles = [dds.video_stream_profile(p[0], getattr(dds.video_encoding, p[1]), p[2], p[3])
                        for p in st["profiles"]]
        server.init_profiles(profiles, st.get("default", 0))
        server.init_options([dds.option.from_json(o) for o in st.get("options", [])])
        if spec.get("images") and st["kind"] != "motion":
            server.on_readers_changed(images.on_readers_changed)  # before init(), which opens the stream
        streams.append(server)
    extrinsics = {}
    for frm, to, rotation, translation in spec.get("extrinsics", []):
        e = dds.extrinsics()
        e.rotation, e.translation = tuple(rotation), tuple(translation)
        extrinsics[(frm, to)] = e
    server = dds.device_server(participant, info["topic-root"])
    if spec.get("images"):
        images.streams[info["topic-root"]] = streams
        server.on_control(images.on_control)
    server.init(streams, [dds.option.from_json(o) for o in spec.get("device-options", [])], extrinsics)
    server.broadcast(dds.message.device_info.from_json(dict(info)))
    return server


_REPLY_DELAY = 0.002


class Images:
    """Streams blank frames to whoever subscribes (realdds streams start on a reader match)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.asked: Dict[Any, List[Any]] = {}  # stream server -> [fps, encoding, width, height] from `open-streams`
        self.running: Dict[Any, threading.Event] = {}  # stream server -> the Event that stops its publisher
        # topic-root -> its stream servers: kept, so that realdds hands the callbacks these very
        # objects (pybind finds a live wrapper again), which key the two maps above
        self.streams: Dict[str, List[Any]] = {}

    def on_control(self, server: Any, control_id: str, control: Dict[str, Any], reply: Dict[str, Any]) -> bool:
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

    def on_readers_changed(self, stream: Any, readers: int) -> None:
        dds = _pyrealdds()
        with self.lock:
            if readers > 0 and stream not in self.running:
                fps, encoding, width, height = self.asked.get(stream) or stream.default_profile().to_json()
                stream.start_streaming(dds.video_encoding(encoding), width, height)
                stop = self.running[stream] = threading.Event()
                threading.Thread(target=self.publish, args=(stream, fps, encoding, width, height, stop),
                                 daemon=True).start()
            elif readers == 0 and stream in self.running:
                self._stop(stream)

    def _stop(self, stream: Any) -> None:
        self.running.pop(stream).set()
        try:
            stream.stop_streaming()
        except Exception:  # noqa: BLE001  (already stopped by realdds)
            pass

    def forget(self, topic_root: str) -> None:
        """Before a device server goes: its publishers end (they hold its streams)."""
        with self.lock:
            for st in self.streams.pop(topic_root, []):
                if st in self.running:
                    self._stop(st)
                self.asked.pop(st, None)

    @staticmethod
    def publish(stream: Any, fps: float, encoding: str, width: int, height: int, stop: threading.Event) -> None:
        dds = _pyrealdds()
        image = dds.message.image()
        image.width, image.height = width, height
        image.data = [0] * (width * height * BYTES_PER_PIXEL.get(encoding, 2))  # made once: pybind takes a list
        period, t = 1.0 / fps, time.monotonic()
        while not stop.is_set():
            image.timestamp = dds.now()
            try:
                stream.publish_image(image)
            except Exception:  # noqa: BLE001  (stopped between the check and the write)
                break
            t += period
            stop.wait(max(0.0, t - time.monotonic()))


images = Images()


def main(argv: Optional[List[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m rsdiscovery.camera_server",
                                description="Serve a D555-like RealSense network camera (realdds) without "
                                            "hardware, until Ctrl-C: librealsense lists and opens it, and it "
                                            "streams blank Depth, Infrared 1 and Color images.")
    p.add_argument("--domain", type=int, default=0, help="DDS domain (0-232; default 0)")
    p.add_argument("--serial", action="append", metavar="SERIAL",
                   help="serial of a camera to serve (default 555000000001); repeat for several")
    p.add_argument("--name", default="rsdiscovery-camera-server", help="the DDS participant's name")
    args = p.parse_args(argv)
    dds = _pyrealdds()
    participant = dds.participant()
    participant.init(args.domain, args.name)
    servers = [make_server(participant, d555_info(s), "d555") for s in args.serial or ["555000000001"]]
    for s in args.serial or ["555000000001"]:
        print(json.dumps(d555_info(s)), flush=True)
    print(f"serving {len(servers)} camera(s) on DDS domain {args.domain}; Ctrl-C stops", file=sys.stderr, flush=True)
    done = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: done.set())
    done.wait()
    for topic_root in list(images.streams):
        images.forget(topic_root)
    for server in servers:
        server.broadcast_disconnect()  # 'stopping': the daemon drops the cameras at once
    return 0


if __name__ == "__main__":
    sys.exit(main())
