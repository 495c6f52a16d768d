#!/usr/bin/env python3
"""One way from "the daemon lists camera X" to a usable device, and on to its first frame,
timed as a user's program meets it: run fresh by bench/run's `open` section, once per path
and repetition. Interpreter start and imports are not timed (they are done first); the
context or participant is.

    open_paths.py PATH --domain D --serial S --topic-root R [--frame]

PATH:
  query-devices    rs.context({"dds": {"enabled": true, "domain": D}}).query_devices()
  devices-changed  a context with "query-devices-max": 0 and a devices-changed callback,
                   waiting for the camera (what rsdiscovery.librealsense does, by hand)
  librealsense     rsdiscovery.librealsense.device(serial)
  realdds          rsdiscovery.realdds.open(serial)

Prints one JSON line: {"ready_s", "frame_s" (with --frame), "marks" (realdds: where the
time went, see rsdiscovery.realdds.last_open), "frame": {...}} or {"error": ...}. The first
frame: realdds' first image of the Depth stream (rsdiscovery.realdds.first_frame); the others
a pipeline on the context with the camera and its depth stream enabled, wait_for_frames().
The daemon is found through $RS_DISCOVERY_ENDPOINT.
"""
import argparse
import json
import os
import sys
import threading
import time

import pyrealsense2 as rs
from pyrealsense2 import pyrealdds  # noqa: F401  (imported, not timed)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "client", "python", "src"))
import rsdiscovery  # noqa: E402
import rsdiscovery.librealsense  # noqa: E402
import rsdiscovery.realdds  # noqa: E402


def by_port(root):
    return lambda d: d.supports(rs.camera_info.physical_port) and d.get_info(rs.camera_info.physical_port) == root


def pipeline_frame(ctx, serial):
    pipe = rs.pipeline(ctx)
    cfg = rs.config()
    cfg.enable_device(serial)
    cfg.enable_stream(rs.stream.depth)
    pipe.start(cfg)
    try:
        f = pipe.wait_for_frames(10000).get_depth_frame()
        return {"width": f.get_width(), "height": f.get_height(), "timestamp_ms": f.get_timestamp()}, pipe
    except BaseException:
        pipe.stop()
        raise


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("path", choices=["query-devices", "devices-changed", "librealsense", "realdds"])
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--serial", required=True)
    ap.add_argument("--topic-root", required=True)
    ap.add_argument("--frame", action="store_true")
    a = ap.parse_args()
    out = {"path": a.path}
    keep = []
    t0 = time.monotonic()
    if a.path == "realdds":
        dev = rsdiscovery.realdds.open(a.serial, timeout=10)
        out["ready_s"] = time.monotonic() - t0
        out["marks"] = rsdiscovery.realdds.last_open.get("marks")
        out["prods"] = rsdiscovery.realdds.last_open.get("prods", 0)
        if a.frame:
            f = rsdiscovery.realdds.first_frame(dev, "Depth", timeout=10)
            out["frame_s"] = time.monotonic() - t0
            out["frame"] = {"width": f.width, "height": f.height, "encoding": f.encoding, "timestamp": f.timestamp}
        keep.append(dev)
    else:
        if a.path == "librealsense":
            ctx, dev = rsdiscovery.librealsense.device(a.serial, timeout=10)
        else:
            match = by_port(a.topic_root)
            if a.path == "query-devices":
                ctx = rs.context({"dds": {"enabled": True, "domain": a.domain}})
                found = [d for d in ctx.query_devices() if match(d)]
                if not found:
                    raise SystemExit(json.dumps({"error": "query_devices() did not list the camera"}))
                dev = found[0]
            else:
                ctx = rs.context({"dds": {"enabled": True, "domain": a.domain, "query-devices-max": 0}})
                got, box = threading.Event(), []

                def changed(info):
                    for d in info.get_new_devices():
                        if match(d):
                            box.append(d)
                            got.set()
                ctx.set_devices_changed_callback(changed)
                box += [d for d in ctx.query_devices() if match(d)]
                if not box and not got.wait(10):
                    raise SystemExit(json.dumps({"error": "no devices-changed callback for the camera in 10 s"}))
                dev = box[0]
        out["ready_s"] = time.monotonic() - t0
        if a.frame:
            out["frame"], pipe = pipeline_frame(ctx, dev.get_info(rs.camera_info.serial_number))
            out["frame_s"] = time.monotonic() - t0
            keep.append(pipe)
        keep += [ctx, dev]
    print(json.dumps(out), flush=True)
    for k in keep:
        if isinstance(k, rs.pipeline):
            k.stop()


if __name__ == "__main__":
    main()
