#!/usr/bin/env python3
"""Open a RealSense camera that rs-discoveryd lists, with librealsense, and print its first frame.

With DDS, librealsense's query_devices() waits at least 3 s on every call. The daemon
knows which camera is where: rsdiscovery.librealsense.device() makes a context on the
camera's DDS domain with that wait off and takes the camera as soon as librealsense has it
(a USB camera: a context without DDS). Existing code then goes on as usual: a pipeline on
that context, config.enable_device(serial).

    python3 open_camera_librealsense.py                 # the first camera the daemon lists
    python3 open_camera_librealsense.py 123622270732    # the camera with this serial (or id, or topic-root)
    RS_DISCOVERY_ENDPOINT=http://127.0.0.1:8035 python3 open_camera_librealsense.py

Needs the rsdiscovery Python package and pyrealsense2 (2.56 or later for network
cameras). rsdiscovery is not on PyPI: install the Debian package python3-rsdiscovery
(packaging/build-deb) and `pip install pyrealsense2`, or, from a clone of the repository,
`pip install './client/python[realdds]'`.
"""
import sys
import time

import pyrealsense2 as rs

import rsdiscovery
import rsdiscovery.librealsense


def pick(key=None, timeout=10.0):
    """The camera to open: by serial, id or topic-root, else the first one."""
    try:
        return rsdiscovery.get_device(key) if key else rsdiscovery.wait_for(timeout=timeout)
    except rsdiscovery.NotFound as e:
        sys.exit(f"{e}{': it names several: ' + ', '.join(e.ids) if e.ids else ''}")
    except TimeoutError:
        sys.exit(f"no camera within {timeout:g} s")


def main():
    cam = pick(sys.argv[1] if len(sys.argv) > 1 else None)
    where = f"DDS domain {cam.domain}" if cam.domain is not None else "USB"
    print(f"{cam.name} serial {cam.serial or '?'} on {where} ({cam.id})")
    t0 = time.monotonic()
    try:
        ctx, dev = rsdiscovery.librealsense.device(cam)
    except rsdiscovery.OpenError as e:  # Pyrealsense2Missing, DeviceGone, NotReady
        sys.exit(str(e))
    serial = dev.get_info(rs.camera_info.serial_number)
    print(f"librealsense has it in {(time.monotonic() - t0) * 1000:.0f} ms: {dev.get_info(rs.camera_info.name)} "
          f"{serial}, sensors: {', '.join(s.get_info(rs.camera_info.name) for s in dev.query_sensors())}")

    # From here on, plain librealsense: the pipeline on the context that has the camera.
    pipe = rs.pipeline(ctx)
    cfg = rs.config()
    cfg.enable_device(serial)
    pipe.start(cfg)
    try:
        frames = pipe.wait_for_frames(5000)
        for f in frames:
            if f.is_video_frame():
                v = f.as_video_frame()
                size = f"{v.get_width()}x{v.get_height()}"
            else:
                size = f"{f.get_data_size()} bytes"
            print(f"first frame of {f.get_profile().stream_name()}: {size} {f.get_profile().format()}, "
                  f"timestamp {f.get_timestamp():.3f} ms ({f.get_frame_timestamp_domain()}), "
                  f"{(time.monotonic() - t0) * 1000:.0f} ms after the call")
    finally:
        pipe.stop()


if __name__ == "__main__":
    main()
