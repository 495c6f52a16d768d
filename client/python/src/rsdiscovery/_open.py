"""What rsdiscovery.realdds and rsdiscovery.librealsense share: their errors, and the camera
the caller means (a device from the daemon, or an id, serial or topic-root to ask it for).

Standard library only: pyrealsense2 is imported by those modules, when they are called."""
from __future__ import annotations

import json
import time
import urllib.parse
from typing import Any, Dict, Mapping, Optional, Union

from ._client import Client
from ._errors import MalformedReply, RSDiscoveryError
from ._model import Device
from ._query import _check_seconds

__all__ = ["OpenError", "Pyrealsense2Missing", "NotANetworkCamera", "DeviceGone", "NotReady"]


class OpenError(RSDiscoveryError):
    """Base of the errors of opening a camera (rsdiscovery.realdds, rsdiscovery.librealsense)."""


class Pyrealsense2Missing(OpenError, ImportError):
    """pyrealsense2 (with its DDS part, pyrealdds, for rsdiscovery.realdds) cannot be imported.
    It is an optional extra of this package: ``pip install 'rsdiscovery[realdds]'`` from the
    repository, or ``pip install pyrealsense2`` (2.56 or later for DDS)."""


class NotANetworkCamera(OpenError):
    """rsdiscovery.realdds was given a camera the daemon sees on USB only: realdds opens
    network (DDS) cameras; rsdiscovery.librealsense.device opens both."""


class DeviceGone(OpenError):
    """The camera is no longer there: the daemon does not list it any more (its server
    stopped, was unplugged or lost its network)."""


class NotReady(OpenError, TimeoutError):
    """The camera did not get usable within the timeout. ``stage`` says how far it got:

    - ``"discovery"``: this process never heard the camera's server (DDS participant);
    - ``"matching"``: it heard the server but not the camera's notification and control
      topics (endpoint discovery);
    - ``"initialization"``: the camera's server did not send its whole initialization set
      (device header and options, every stream's header and options);
    - ``"listing"``: librealsense did not list the camera (rsdiscovery.librealsense);
    - ``"streaming"``: no frame arrived (rsdiscovery.realdds.first_frame).
    """

    def __init__(self, message: str, stage: str, elapsed: float) -> None:
        super().__init__(message)
        self.stage = stage
        self.elapsed = elapsed


# Fields the daemon adds to a camera's device-info (proto/openapi.yaml, Device); the rest is
# the device-info exactly as the camera's server sent it.
_DAEMON_FIELDS = frozenset({"id", "source", "sources", "domain", "first-seen", "last-seen", "server", "usb",
                            "warnings", "merged-into", "state"})


def as_device(device: Union[Device, Mapping[str, Any]]) -> Device:
    """A Device, also from its JSON (a dict, as the daemon or ``rs-discover --json`` gave it)."""
    return device if isinstance(device, Device) else Device.from_json(device)


def device_info(device: Union[Device, Mapping[str, Any]]) -> Dict[str, Any]:
    """The camera's realdds device-info, as its server sent it, from the daemon's document."""
    info = {k: v for k, v in as_device(device).raw.items() if k not in _DAEMON_FIELDS}
    if not info.get("recovery"):
        info.pop("recovery", None)  # the daemon writes false for every camera; realdds omits it
    return info


def is_network(device: Device) -> bool:
    return device.is_network


def is_usb(device: Device) -> bool:
    return device.is_usb


def resolve(device: Any, endpoint: Any, timeout: Any) -> Device:
    """The daemon's document of the camera: `device` itself when it is one (from
    list_devices, get_device, wait_for or a watch; or its JSON, a dict, as the daemon or
    ``rs-discover --json`` gave it), else the daemon is asked for the id, serial or topic-root
    `device` (NotFound when it lists none, or several)."""
    _check_seconds("timeout", timeout, allow_zero=False)
    if isinstance(device, Device):
        return device
    if isinstance(device, Mapping):
        try:
            if not isinstance(device.get("name"), str):
                raise MalformedReply("no name")
            return Device.from_json(device)
        except MalformedReply:
            raise ValueError("device must be a camera from rs-discoveryd (from list_devices(), get_device() or "
                             "wait_for(), or its JSON with its 'id' and 'name'), or its id, serial or "
                             "topic-root") from None
    if isinstance(device, str) and device:
        return Client(endpoint).get_device(device)
    raise ValueError(f"device must be a camera from rs-discoveryd, or its id, serial or topic-root, not {device!r}")


class StillListed:
    """Asks the daemon, at most every `period` seconds, whether the camera is still listed,
    so that a camera that went away is told apart from a slow one."""

    def __init__(self, device: Device, endpoint: Any, first: float = 0.5, period: float = 0.5) -> None:
        self._path = "/v1/devices/" + urllib.parse.quote(device.id, safe="")
        self._endpoint = endpoint
        self._next = time.monotonic() + first
        self._period = period
        self._client: Optional[Client] = None

    def gone(self, force: bool = False) -> bool:
        """True only when the daemon answered that it does not list the camera (with its
        table complete); unreachable or unsure is not gone."""
        now = time.monotonic()
        if not force and now < self._next:
            return False
        self._next = now + self._period
        try:
            if self._client is None:
                self._client = Client(self._endpoint, timeout=1.0, complete_timeout=0)
            status, body = self._client._request(self._path)
            if status == 410:  # it was listed and left: the daemon keeps it as gone
                return True
            if status != 404:
                return False
            doc = json.loads(body)
            return isinstance(doc, dict) and doc.get("complete", True) is not False
        except (RSDiscoveryError, OSError, ValueError):
            return False


def gone_error(device: Device, elapsed: float) -> DeviceGone:
    return DeviceGone(f"camera {device.id} ({device.name}) is gone: rs-discoveryd no longer lists it "
                      f"(after {elapsed:.2f} s)")
