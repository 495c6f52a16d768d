#!/usr/bin/env python3
"""librealsense's own view of the network cameras, as a program using it sees them:
one rs.context with DDS on (its device watcher, its lease, its 5 s initialization
wait) kept alive, printing a JSON line per change it reports through
set_devices_changed_callback:

  {"ready": true}                                   the context exists
  {"t": MONOTONIC, "event": "added", "serial": S}   a camera it can use now
  {"t": MONOTONIC, "event": "removed", "serial": S} a camera it lost

"t" is time.monotonic() (CLOCK_MONOTONIC), comparable with the test's own clock.
It runs until stdin closes.
"""
import argparse
import json
import sys
import threading
import time

import pyrealsense2 as rs


def say(**msg):
    sys.stdout.write(json.dumps(msg) + "\n")
    sys.stdout.flush()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--domain", type=int, required=True)
    args = ap.parse_args()

    ctx = rs.context({"dds": {"enabled": True, "domain": args.domain}})
    known = {}  # serial -> device, as last reported
    lock = threading.Lock()

    def serial_of(dev):
        return dev.get_info(rs.camera_info.serial_number)

    def changed(info):
        now = time.monotonic()
        with lock:
            for serial, dev in list(known.items()):
                if info.was_removed(dev):
                    del known[serial]
                    say(t=now, event="removed", serial=serial)
            for dev in info.get_new_devices():
                serial = serial_of(dev)
                if serial not in known:
                    known[serial] = dev
                    say(t=now, event="added", serial=serial)

    ctx.set_devices_changed_callback(changed)
    # Those found before the callback was set.
    with lock:
        for dev in ctx.query_devices():
            serial = serial_of(dev)
            if serial not in known:
                known[serial] = dev
                say(t=time.monotonic(), event="added", serial=serial)
    say(ready=True)
    sys.stdin.read()


if __name__ == "__main__":
    main()
