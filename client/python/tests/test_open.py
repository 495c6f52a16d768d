"""rsdiscovery.realdds and rsdiscovery.librealsense where no camera is needed: the optional
extra, the typed errors before anything is opened, and librealsense's context settings and
matching against a stand-in pyrealsense2 (the real one, with real cameras, is tested by
tests/client/test_open_camera.py). These run where pyrealsense2 is not installed too."""
import importlib.metadata
import sys
import threading
import time
import types

import pytest

import rsdiscovery
import rsdiscovery.librealsense
import rsdiscovery.realdds
from rsdiscovery._open import device_info

NOBODY = "unix:/nonexistent/rsd.sock"  # no daemon: a gone check answers "unsure", never "gone"

DDS_CAMERA = {"id": "dds-7-realsense.D555_555", "name": "Intel RealSense D555", "serial": "555", "product-line": "D500",
              "topic-root": "realsense/D555_555", "x-vendor": [1, 2], "source": "dds", "sources": ["dds"], "domain": 7,
              "recovery": False, "first-seen": "2026-12-01T00:00:00Z", "last-seen": "2026-12-01T00:00:01Z",
              "server": {"participant-name": "cam", "addresses": ["10.0.0.2"]}}
USB_CAMERA = {"id": "usb-3-1.2", "name": "Intel RealSense D435", "serial": "435", "product-line": "D400",
              "source": "usb", "sources": ["usb"], "recovery": False, "usb": {"bus": 3, "address": 4}}


def test_the_extra_is_declared_and_not_a_dependency():
    meta = importlib.metadata.metadata("rsdiscovery")
    assert {"realdds", "librealsense"} <= set(meta.get_all("Provides-Extra") or [])
    requires = meta.get_all("Requires-Dist") or []
    assert requires and all("extra ==" in r for r in requires), requires  # pyrealsense2 only with the extra


def test_the_device_info_is_what_the_server_sent():
    assert device_info(DDS_CAMERA) == {"name": "Intel RealSense D555", "serial": "555", "product-line": "D500",
                                       "topic-root": "realsense/D555_555", "x-vendor": [1, 2]}
    assert device_info(dict(DDS_CAMERA, recovery=True))["recovery"] is True


def test_without_pyrealsense2_both_raise_a_typed_import_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyrealsense2", None)
    for call in (lambda: rsdiscovery.realdds.open(DDS_CAMERA, endpoint=NOBODY),
                 lambda: rsdiscovery.realdds.participant(7),
                 lambda: rsdiscovery.librealsense.device(DDS_CAMERA, endpoint=NOBODY),
                 lambda: rsdiscovery.librealsense.device(USB_CAMERA, endpoint=NOBODY)):
        with pytest.raises(rsdiscovery.Pyrealsense2Missing) as e:
            call()
        assert isinstance(e.value, ImportError) and isinstance(e.value, rsdiscovery.OpenError)
        assert "pip install 'rsdiscovery[realdds]'" in str(e.value)


def test_errors_before_anything_is_opened(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyrealsense2", None)  # none of these gets as far as importing it
    with pytest.raises(rsdiscovery.NotANetworkCamera, match="rsdiscovery.librealsense.device"):
        rsdiscovery.realdds.open(USB_CAMERA, endpoint=NOBODY)
    for bad in ({"serial": "555"}, 42, "", None):
        with pytest.raises(ValueError):
            rsdiscovery.realdds.open(bad, endpoint=NOBODY)
        with pytest.raises(ValueError):
            rsdiscovery.librealsense.device(bad, endpoint=NOBODY)
    for timeout in (0, -1, "5", True):
        with pytest.raises(ValueError):
            rsdiscovery.realdds.open(DDS_CAMERA, timeout=timeout, endpoint=NOBODY)
        with pytest.raises(ValueError):
            rsdiscovery.librealsense.device(DDS_CAMERA, timeout=timeout, endpoint=NOBODY)
    with pytest.raises(ValueError):
        rsdiscovery.realdds.participant(233)
    # An id, serial or topic-root is asked of the daemon: no daemon, the usual error.
    with pytest.raises(rsdiscovery.DaemonNotRunning):
        rsdiscovery.realdds.open("555", endpoint=NOBODY)
    assert issubclass(rsdiscovery.NotReady, TimeoutError) and issubclass(rsdiscovery.DeviceGone, rsdiscovery.OpenError)
    e = rsdiscovery.NotReady("not ready", "initialization", 1.5)
    assert (str(e), e.stage, e.elapsed) == ("not ready", "initialization", 1.5)


class FakeDevice:
    def __init__(self, **info):
        self.info = info

    def supports(self, what):
        return what in self.info

    def get_info(self, what):
        return self.info[what]


def fake_pyrealsense2(devices_now=(), devices_later=(), later=0.05):
    """A stand-in pyrealsense2 module: contexts record their settings; `devices_later` arrive
    through the devices-changed callback `later` seconds after it is set."""
    rs = types.ModuleType("pyrealsense2")
    rs.camera_info = types.SimpleNamespace(serial_number="serial", physical_port="port", name="name")
    rs.contexts = []

    class Context:
        def __init__(self, settings=None):
            self.settings = settings
            rs.contexts.append(self)

        def set_devices_changed_callback(self, cb):
            if devices_later:
                info = types.SimpleNamespace(get_new_devices=lambda: list(devices_later))
                threading.Timer(later, cb, args=(info,)).start()

        def query_devices(self):
            return list(devices_now)

    rs.context = Context
    return rs


def test_librealsense_usb_camera_on_a_context_without_dds(monkeypatch):
    other, mine = FakeDevice(serial="111", port="2-1"), FakeDevice(serial="435", port="3-1.2")
    rs = fake_pyrealsense2(devices_now=[other, mine])
    monkeypatch.setitem(sys.modules, "pyrealsense2", rs)
    ctx, dev = rsdiscovery.librealsense.device(USB_CAMERA, endpoint=NOBODY)
    assert dev is mine and ctx.settings == {"dds": {"enabled": False}}


def test_librealsense_network_camera_by_its_topic_root_when_librealsense_has_it(monkeypatch):
    # The same serial on USB is not it: a DDS camera is matched by its topic-root (librealsense's
    # physical port of a DDS device).
    usb_twin = FakeDevice(serial="555", port="3-1.1")
    mine = FakeDevice(serial="555", port="realsense/D555_555")
    rs = fake_pyrealsense2(devices_now=[usb_twin], devices_later=[mine], later=0.1)
    monkeypatch.setitem(sys.modules, "pyrealsense2", rs)
    t0 = time.monotonic()
    ctx, dev = rsdiscovery.librealsense.device(DDS_CAMERA, endpoint=NOBODY)
    assert dev is mine and time.monotonic() - t0 < 2
    assert ctx.settings == {"dds": {"enabled": True, "domain": 7, "query-devices-max": 0}}
    assert rsdiscovery.librealsense.context_settings(DDS_CAMERA) == ctx.settings
    # Seen on both: over DDS (its USB side belongs to the server that serves it).
    both = dict(DDS_CAMERA, sources=["dds", "usb"])
    assert rsdiscovery.librealsense.context_settings(both)["dds"]["enabled"] is True


def test_librealsense_never_listing_it_is_not_ready(monkeypatch):
    rs = fake_pyrealsense2(devices_now=[FakeDevice(serial="1", port="realsense/D455_1")])
    monkeypatch.setitem(sys.modules, "pyrealsense2", rs)
    t0 = time.monotonic()
    with pytest.raises(rsdiscovery.NotReady) as e:
        rsdiscovery.librealsense.device(DDS_CAMERA, timeout=0.3, endpoint=NOBODY)
    assert e.value.stage == "listing" and 0.3 <= time.monotonic() - t0 < 2
    assert "on DDS domain 7" in str(e.value)
