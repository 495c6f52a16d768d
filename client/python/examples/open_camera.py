#!/usr/bin/env python3
"""Pick a RealSense camera from rs-discoveryd and open it with pyrealsense2.

librealsense's own DDS discovery waits about 3 s on every query; the daemon already
knows the cameras, so ask it which one to use and on which DDS domain, then let
pyrealsense2 open exactly that one.

    python3 open_camera.py                 # the first camera the daemon knows
    python3 open_camera.py 123622270732    # the camera with this serial
    RS_DISCOVERY_ENDPOINT=http://127.0.0.1:8035 python3 open_camera.py

Needs: pip install rsdiscovery pyrealsense2 (pyrealsense2 2.56 or later for DDS).
"""
import sys

import rsdiscovery


def pick(serial=None, timeout=10.0):
    """The camera to open: by serial, else the first one (waiting for it if needed)."""
    want = (lambda d: d.get("serial") == serial) if serial else None
    try:
        return rsdiscovery.wait_for(want, timeout=timeout)
    except TimeoutError:
        sys.exit(f"no camera{' with serial ' + serial if serial else ''} within {timeout:g} s")


def open_with_pyrealsense2(device):
    import pyrealsense2 as rs

    if device.get("source") == "dds" or "dds" in device.get("sources", []):
        # Look only on the camera's own domain; librealsense then finds it there.
        ctx = rs.context({"dds": {"enabled": True, "domain": device["domain"]}})
    else:
        ctx = rs.context()
    for dev in ctx.query_devices():
        if dev.get_info(rs.camera_info.serial_number) == device.get("serial"):
            return dev
    return None


def main():
    device = pick(sys.argv[1] if len(sys.argv) > 1 else None)
    where = f"DDS domain {device['domain']}" if "domain" in device else "USB"
    addresses = ", ".join(device.get("server", {}).get("addresses", [])) or "-"
    print(f"{device['name']} serial {device.get('serial', '?')} on {where} at {addresses} ({device['id']})")
    dev = open_with_pyrealsense2(device)
    if dev is None:
        sys.exit("pyrealsense2 did not find it (is it a realdds camera, and is the DDS domain reachable?)")
    print("opened:", dev.get_info(__import__("pyrealsense2").camera_info.name))


if __name__ == "__main__":
    main()
