#!/usr/bin/env python3
"""Open a network RealSense camera that rs-discoveryd lists, with realdds, and print its first frame.

librealsense's own DDS discovery waits about 3 s on every query; the daemon already knows
the cameras, their DDS domain and the device-info their servers sent, so the camera is
opened from that at once (rsdiscovery.realdds.open: a ready pyrealdds device, its streams,
options and profiles received), and the first image of a stream follows.

    python3 open_camera.py                      # the first network camera the daemon lists
    python3 open_camera.py 123622270732         # the camera with this serial (or id, or topic-root)
    python3 open_camera.py 123622270732 Color   # ... and the first frame of its Color stream
    RS_DISCOVERY_ENDPOINT=http://127.0.0.1:8035 python3 open_camera.py

A USB camera is opened with librealsense: see open_camera_librealsense.py.

Needs the rsdiscovery Python package with its optional extra pyrealsense2 (2.56 or later,
with DDS). rsdiscovery is not on PyPI: install the Debian package python3-rsdiscovery
(packaging/build-deb) and `pip install pyrealsense2`, or, from a clone of the repository,
`pip install './client/python[realdds]'`.
"""
import sys
import time

import rsdiscovery
import rsdiscovery.realdds


def pick(key=None, timeout=10.0):
    """The camera to open: by serial, id or topic-root, else the first network camera."""
    try:
        if key:
            return rsdiscovery.get_device(key)
        return rsdiscovery.wait_for(timeout=timeout, source="dds")
    except rsdiscovery.NotFound as e:
        sys.exit(f"{e}{': it names several: ' + ', '.join(e.ids) if e.ids else ''}")
    except TimeoutError:
        sys.exit(f"no network camera within {timeout:g} s")


def main():
    cam = pick(sys.argv[1] if len(sys.argv) > 1 else None)
    addresses = ", ".join(cam.server.addresses if cam.server else ()) or "-"
    where = f"DDS domain {cam.domain} at {addresses}" if cam.domain is not None else "USB"
    print(f"{cam.name} serial {cam.serial or '?'} on {where} ({cam.id})")
    t0 = time.monotonic()
    try:
        dev = rsdiscovery.realdds.open(cam)
    except rsdiscovery.NotANetworkCamera:
        sys.exit("a USB camera: open it with open_camera_librealsense.py")
    except rsdiscovery.OpenError as e:  # Pyrealsense2Missing, DeviceGone, NotReady
        sys.exit(str(e))
    ready = time.monotonic() - t0
    print(f"ready in {ready * 1000:.0f} ms: {dev.n_streams()} streams")
    for s in dev.streams():
        p = s.default_profile()
        print(f"  {s.name():12} {s.sensor_name():16} {len(s.profiles())} profiles, default {p.to_string()}")
    try:
        frame = rsdiscovery.realdds.first_frame(dev, sys.argv[2] if len(sys.argv) > 2 else None)
    except (ValueError, rsdiscovery.NotReady) as e:
        sys.exit(str(e))
    stamp = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(frame.timestamp))
    stamp += f".{int(frame.timestamp % 1 * 1e6):06d}"
    print(f"first frame of {frame.stream}: {frame.width}x{frame.height} {frame.encoding}, {len(frame.data)} bytes, "
          f"timestamp {frame.timestamp:.6f} ({stamp}), {(time.monotonic() - t0) * 1000:.0f} ms after the call")


if __name__ == "__main__":
    main()
