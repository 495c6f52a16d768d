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
"""
import argparse
import gc
import json
import sys
import time

import pyrealsense2.pyrealdds as dds


DEFAULT_STREAMS = {"streams": [{"kind": "color", "name": "Color", "sensor": "RGB Camera",
                                 "profiles": [[30, "rgb", 640, 480]], "default": 0,
                                 "options": [["Backlight Compensation", 0, 0, 1, 1, 0, "desc"]]}]}

STREAM_SERVERS = {"color": dds.color_stream_server, "depth": dds.depth_stream_server, "ir": dds.ir_stream_server,
                  "motion": dds.motion_stream_server}


def make_server(participant, info, spec=None):
    """A device_server for `info` with the streams, options and extrinsics of `spec`
    (what the daemon's Camera Discovery must report back):
      {"streams": [{"kind": "color|depth|ir|motion", "name", "sensor",
                    "profiles": [[fps, encoding, width, height]] (motion: [[fps]]),
                    "default": index, "options": [option JSON]}],
       "device-options": [option JSON], "extrinsics": [[from, to, [9 rotation], [3 translation]]]}"""
    spec = spec or DEFAULT_STREAMS
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
        streams.append(server)
    extrinsics = {}
    for frm, to, rotation, translation in spec.get("extrinsics", []):
        e = dds.extrinsics()
        e.rotation, e.translation = tuple(rotation), tuple(translation)
        extrinsics[(frm, to)] = e
    server = dds.device_server(participant, info["topic-root"])
    server.init(streams, [dds.option.from_json(o) for o in spec.get("device-options", [])], extrinsics)
    server.broadcast(dds.message.device_info.from_json(info))
    return server


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--name", default="test-server")
    ap.add_argument("--device", action="append", default=[], help="device-info JSON")
    args = ap.parse_args()

    participant = dds.participant()
    participant.init(args.domain, args.name)
    servers = {}
    for text in args.device:
        info = json.loads(text)
        servers[info["topic-root"]] = make_server(participant, info)
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
