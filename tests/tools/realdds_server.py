#!/usr/bin/env python3
"""A realdds camera server driven over stdin, for tests.

It runs librealsense's own realdds (pyrealsense2.pyrealdds, on Fast DDS), so the
daemon sees exactly what a networked RealSense camera sends. One participant,
any number of devices. Commands, one JSON object per line on stdin; each is
answered with one JSON line on stdout ({"ok": true} or {"ok": false, "error": ...}):

  {"cmd": "add", "info": {...device-info...}}   new device_server, broadcasts info
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


def make_server(participant, info):
    color = dds.color_stream_server("Color", "RGB Camera")
    color.init_profiles([dds.video_stream_profile(30, dds.video_encoding.rgb, 640, 480)], 0)
    color.init_options([dds.option.from_json(["Backlight Compensation", 0, 0, 1, 1, 0, "desc"])])
    server = dds.device_server(participant, info["topic-root"])
    server.init([color], [], {})
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
                servers[msg["info"]["topic-root"]] = make_server(participant, msg["info"])
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
