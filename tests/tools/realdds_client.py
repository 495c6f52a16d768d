#!/usr/bin/env python3
"""A realdds client of one camera, for tests: what an application using
librealsense's realdds (pyrealsense2.pyrealdds) does. It makes a participant named
--name and `dds.device(p, info)` for --info (a control writer, a notification
reader), waits until the device is ready, then for each --stream opens that
stream's topic (rt/<topic-root>_<name>, as librealsense does) and streams it.
It prints {"device": T} as it makes the device (T: its time.monotonic(), one clock
for every process of the host), {"ready": true, "streams": [...]} once ready, and
then waits for a line on stdin:
"quit" ends it cleanly (every entity deleted); a closed stdin too.
"""
import argparse
import gc
import json
import sys
import time

import pyrealsense2.pyrealdds as dds


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--name", default="test-client")
    ap.add_argument("--info", required=True, help="the camera's device-info JSON")
    ap.add_argument("--stream", action="append", default=[])
    args = ap.parse_args()
    info = json.loads(args.info)
    p = dds.participant()
    p.init(args.domain, args.name)
    print(json.dumps({"device": time.monotonic()}), flush=True)
    dev = dds.device(p, dds.message.device_info.from_json(info))
    deadline = time.monotonic() + 20
    while not dev.is_ready():  # polled: wait_until_ready sleeps 500 ms a turn
        if time.monotonic() > deadline:
            print(json.dumps({"ready": False}), flush=True)
            return 1
        time.sleep(0.01)
    streams = {s.name(): s for s in dev.streams()}
    subscriber = dds.subscriber(p)
    opened = []
    for name in args.stream:
        s = streams[name]
        s.open("rt/" + info["topic-root"] + "_" + name, subscriber)
        s.on_data_available(lambda *a: None)
        s.start_streaming()
        opened.append(s)
    print(json.dumps({"ready": True, "streams": [s.name() for s in opened], "guid": str(p.guid())}), flush=True)
    sys.stdin.readline()
    for s in opened:
        s.stop_streaming()
        s.close()
    del opened, streams, subscriber, dev
    gc.collect()
    del p
    gc.collect()
    return 0


if __name__ == "__main__":
    sys.exit(main())
