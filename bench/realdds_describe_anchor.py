#!/usr/bin/env python3
"""The anchor of bench/run's describe section: what librealsense's own realdds client
(pyrealsense2.pyrealdds, Fast DDS) spends to learn a camera's streams and options, the
same initialization set the daemon collects for GET /v1/devices/{id}/description.

    realdds_describe_anchor.py --domain D

One participant, made once (a warm client, like the daemon). For each device-info
JSON line on stdin: a dds.device for it, then wait_until_ready(); prints
{"topic-root": ..., "ms": ..., "streams": N} (or {"error": ...}). Ends with stdin.
"""
import argparse
import json
import sys
import time

import pyrealsense2.pyrealdds as dds


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    args = ap.parse_args()
    participant = dds.participant()
    participant.init(args.domain, "bench-describe-anchor")
    print(json.dumps({"ready": True}), flush=True)
    keep = []  # a device object going away mid-run would make its server's work noise
    for line in sys.stdin:
        info = json.loads(line)
        device = dds.device(participant, dds.message.device_info.from_json(info))
        t0 = time.monotonic()
        ok = device.wait_until_ready(30000)
        ms = (time.monotonic() - t0) * 1000
        keep.append(device)
        if ok:
            print(json.dumps({"topic-root": info["topic-root"], "ms": ms, "streams": device.n_streams()}), flush=True)
        else:
            print(json.dumps({"topic-root": info["topic-root"], "error": "not ready in 30 s"}), flush=True)


if __name__ == "__main__":
    main()
