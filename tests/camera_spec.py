"""The camera the Camera Discovery tests serve with a real realdds server
(tests/tools/realdds_server.py's `spec`): color, depth, IR and motion streams with
several profiles and options, device options and extrinsics. Shared by the daemon's
tests (interop/test_describe.py) and the clients' (client/test_describe_clients.py),
which check what comes back against it field by field."""

SPEC = {
    "streams": [
        {"kind": "color", "name": "Color", "sensor": "RGB Camera",
         "profiles": [[30, "rgb", 1280, 720], [30, "yuyv", 640, 480], [6, "rgb", 1920, 1080]], "default": 1,
         "options": [["Backlight Compensation", 0, 0, 1, 1, 0, "Enable / disable backlight compensation"],
                     ["Brightness", 0, -64, 64, 1, 0, "UVC image brightness"]]},
        {"kind": "depth", "name": "Depth", "sensor": "Stereo Module",
         "profiles": [[30, "z16", 848, 480], [90, "z16", 424, 240]], "default": 0,
         "options": [["Exposure", 8500, 1, 165000, 1, 8500, "Depth Exposure (usec)"]]},
        {"kind": "ir", "name": "Infrared 1", "sensor": "Stereo Module",
         "profiles": [[30, "y8", 848, 480]], "default": 0, "options": []},
        {"kind": "motion", "name": "Motion", "sensor": "Motion Module", "profiles": [[200], [400]], "default": 0,
         "options": []},
    ],
    "device-options": [["Laser Power", 150, 0, 360, 30, 150, "Manual laser power in mw"]],
    "extrinsics": [["Depth", "Color", [1, 0, 0, 0, 1, 0, 0, 0, 1], [0.015, 0.0, 0.0]]],
}
# realdds' names on the wire for the encodings the spec uses (librealsense's table).
WIRE_FORMAT = {"rgb": "rgb8", "yuyv": "yuv422_yuy2", "z16": "16UC1", "y8": "mono8"}
TYPE = {"color": "color", "depth": "depth", "ir": "ir", "motion": "motion"}
