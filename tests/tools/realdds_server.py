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

`spec` (and --spec for the --device devices) is a spec object or the name of one of SPECS
(rsdiscovery.camera_server, whose make_server serves each device):
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
import os
import sys
import time

import pyrealsense2.pyrealdds as dds

# The servers themselves are the package's user-facing camera tool (rsdiscovery.camera_server).
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "client", "python", "src"))
from rsdiscovery.camera_server import SPECS, images as _images, make_server  # noqa: E402


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
