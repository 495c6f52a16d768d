"""Open a camera the daemon lists with librealsense (``pyrealsense2``), without the wait of
``query_devices()``.

    import pyrealsense2 as rs
    import rsdiscovery.librealsense

    ctx, dev = rsdiscovery.librealsense.device("123622270732")   # a device, or its id, serial or topic-root
    pipe = rs.pipeline(ctx)
    cfg = rs.config()
    cfg.enable_device(dev.get_info(rs.camera_info.serial_number))
    pipe.start(cfg)

With DDS, librealsense's ``query_devices()`` waits at least 3 s on every call for cameras to
announce themselves. :func:`device` knows from the daemon which camera and which DDS domain:
it makes a context on that domain with the query wait off (``"query-devices-max": 0``) and
waits on its devices-changed callback for that very camera. A USB camera is opened by
librealsense directly, on a context without DDS.

Needs ``pyrealsense2`` (2.56 or later for DDS cameras): ``pip install 'rsdiscovery[realdds]'``.
"""
from __future__ import annotations

import re
import threading
import time
from typing import Any, Callable, Dict, List, Mapping, Tuple, Union

from ._model import Device
from ._open import (DeviceGone, NotReady, OpenError, Pyrealsense2Missing, StillListed, as_device, gone_error,
                    is_network, resolve)

__all__ = ["device", "context_settings", "OpenError", "Pyrealsense2Missing", "DeviceGone", "NotReady"]


def _pyrealsense2() -> Any:
    try:
        import pyrealsense2  # type: ignore[import-not-found, import-untyped, unused-ignore]
    except ImportError as e:
        raise Pyrealsense2Missing("rsdiscovery.librealsense needs pyrealsense2: install the optional extra: "
                                  "pip install 'rsdiscovery[realdds]' (from the repository: "
                                  "pip install './client/python[realdds]'), or pip install pyrealsense2",
                                  name="pyrealsense2") from e
    return pyrealsense2


def context_settings(cam: Union[Device, Mapping[str, Any]]) -> Dict[str, Any]:
    """The librealsense context settings for camera `cam` (a device from the daemon, or its
    JSON): DDS on the camera's domain with the query wait off, or DDS off for a USB camera.
    The same JSON serves ``rs2::context(json)`` in C++ (see the README)."""
    cam = as_device(cam)
    if is_network(cam):
        return {"dds": {"enabled": True, "domain": cam.domain, "query-devices-max": 0}}
    return {"dds": {"enabled": False}}


def _matcher(rs: Any, cam: Device) -> Callable[[Any], bool]:
    """Which rs.device is `cam`: a DDS camera by its topic-root (librealsense's physical port
    of a DDS device, unique on its domain), else by serial."""
    network = is_network(cam)
    root, serial = cam.topic_root, cam.serial

    def info(d: Any, what: Any) -> Any:
        return d.get_info(what) if d.supports(what) else None

    def match(d: Any) -> bool:
        try:
            if network:
                return bool(info(d, rs.camera_info.physical_port) == root)
            return serial is not None and bool(info(d, rs.camera_info.serial_number) == serial)
        except RuntimeError:  # a device that went away while we looked
            return False
    return match


class _Reasons:
    """librealsense's errors while a :func:`device` waits: the reason a camera it sees is not
    listed (a device it refuses to create) is in its log and in the callback's exception, and
    nowhere else. Its log gets one callback per process (librealsense's loggers are global and
    cannot be taken back one by one); it records only while a wait runs."""

    lock = threading.Lock()
    installed = False
    active: List[List[str]] = []
    CAP = 8  # errors kept per wait: the first say why; a busy domain must not grow the list

    @classmethod
    def start(cls, rs: Any) -> List[str]:
        got: List[str] = []
        with cls.lock:
            if not cls.installed:
                try:
                    rs.log_to_callback(rs.log_severity.error, cls._logged)
                    cls.installed = True
                except (AttributeError, RuntimeError, TypeError):  # an older pyrealsense2: the callback's errors only
                    pass
            cls.active.append(got)
        return got

    @classmethod
    def stop(cls, got: List[str]) -> None:
        with cls.lock:  # by identity: two waits' lists may be equal
            cls.active[:] = [g for g in cls.active if g is not got]

    @classmethod
    def add(cls, got: List[str], text: str) -> None:
        # "[rs2_create_device( info_list:0x..., index:0 ) UNKNOWN] why": the call is noise to a user.
        text = re.sub(r"^\[[^\]]*\]\s*", "", text.strip())
        if text and "null pointer passed" not in text and text not in got and len(got) < cls.CAP:
            got.append(text)

    @classmethod
    def _logged(cls, severity: Any, message: Any) -> None:  # on a librealsense thread: never raise
        try:
            raw = message.raw() if callable(getattr(message, "raw", None)) else str(message)
            with cls.lock:
                for got in cls.active:
                    cls.add(got, str(raw))
        except Exception:  # noqa: BLE001
            pass


def device(device_or_serial: Any, *, timeout: float = 5.0, endpoint: Any = None) -> Tuple[Any, Any]:
    """``(context, rs.device)`` for a camera the daemon lists, as soon as librealsense has it.

    `device_or_serial` is a camera from :func:`rsdiscovery.list_devices`,
    :func:`rsdiscovery.get_device` or :func:`rsdiscovery.wait_for`, or its id, serial or
    topic-root (the daemon at `endpoint` is asked; :class:`rsdiscovery.NotFound` when it
    lists none). Keep the context while using the device: existing code goes on with
    ``rs.pipeline(context)`` and ``config.enable_device(serial)``. A camera seen both on USB
    and over DDS is opened over DDS (its USB side belongs to the server that serves it).

    Raises :class:`DeviceGone` when the daemon stops listing the camera meanwhile,
    :class:`NotReady` (a ``TimeoutError``, stage ``"listing"``) when librealsense does not
    list it within `timeout` seconds (with librealsense's own errors meanwhile, such as why it
    refused to make a device: "librealsense said: ..."), and :class:`Pyrealsense2Missing` without pyrealsense2.
    """
    t0 = time.monotonic()
    cam = resolve(device_or_serial, endpoint, timeout)
    rs = _pyrealsense2()
    if not is_network(cam) and not cam.serial:
        raise OpenError(f"camera {cam.id} has no serial: librealsense cannot be asked for it")
    settings = context_settings(cam)
    try:
        ctx = rs.context(settings)
    except TypeError:  # a pyrealsense2 before settings (2.54): no DDS, nothing to wait for
        if is_network(cam):
            raise Pyrealsense2Missing("rsdiscovery.librealsense needs pyrealsense2 2.56 or later for network "
                                      "cameras", name="pyrealsense2") from None
        ctx = rs.context()
    reasons = _Reasons.start(rs)
    try:
        return _wait_listed(rs, ctx, cam, endpoint, t0, timeout, reasons)
    finally:
        _Reasons.stop(reasons)


def _each_device(devices: Any, reasons: List[str]) -> List[Any]:
    """The devices of a librealsense device list, one at a time: librealsense makes each as it
    is taken and raises for one it refuses (its reason, kept), which must not hide the others."""
    out = []
    for i in range(len(devices)):
        try:
            out.append(devices[i])
        except RuntimeError as e:
            with _Reasons.lock:
                _Reasons.add(reasons, str(e))
    return out


def _wait_listed(rs: Any, ctx: Any, cam: Device, endpoint: Any, t0: float, timeout: float,
                 reasons: List[str]) -> Tuple[Any, Any]:
    match = _matcher(rs, cam)
    found = threading.Event()
    box: List[Any] = []

    def changed(info: Any) -> None:  # on a librealsense thread
        try:
            for d in _each_device(info.get_new_devices(), reasons):
                if match(d):
                    box.append(d)
                    found.set()
        except Exception:  # noqa: BLE001  (never let an exception into librealsense)
            pass

    # The callback first, then the list: a camera added in between is not missed.
    ctx.set_devices_changed_callback(changed)
    for d in _each_device(ctx.query_devices(), reasons):  # no wait with "query-devices-max": 0
        if match(d):
            return ctx, d
    still = StillListed(cam, endpoint)
    deadline = t0 + timeout
    while not found.wait(min(0.05, max(0.0, deadline - time.monotonic()))):
        now = time.monotonic()
        if now >= deadline:
            if still.gone(force=True):
                raise gone_error(cam, now - t0)
            where = f"on DDS domain {cam.domain}" if is_network(cam) else "on USB"
            raise NotReady(f"librealsense did not list camera {cam.id} ({cam.name}) {where} within "
                           f"{timeout:g} s{_said(reasons)}", "listing", now - t0)
        if still.gone():
            raise gone_error(cam, now - t0)
    return ctx, box[0]


def _said(reasons: List[str]) -> str:
    with _Reasons.lock:
        if not reasons:
            return ""
        return "; librealsense said: " + "; ".join(reasons)
