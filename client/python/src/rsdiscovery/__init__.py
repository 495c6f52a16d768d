"""Client of rs-discoveryd, the daemon that keeps a live table of Intel RealSense cameras.

Devices are the daemon's JSON documents as dicts (every field verbatim: ``id``, ``name``,
``serial``, ``domain``, ``topic-root``, ``server`` ...). Standard library only.

Opening a camera the daemon lists, at once (these need ``pyrealsense2``, the optional extra
``rsdiscovery[realdds]``, and import it only when called): ``rsdiscovery.realdds.open`` (a
ready ``pyrealdds.device``) and ``rsdiscovery.librealsense.device`` (a librealsense context
and ``rs.device``). Their errors are here too, subclasses of :class:`OpenError`.
"""
from ._client import (
    Client,
    DaemonNotRunning,
    Endpoint,
    Event,
    HTTPError,
    MalformedReply,
    NotFound,
    PermissionDenied,
    RSDiscoveryError,
    VersionMismatch,
    Watcher,
    describe_device,
    domains,
    get_device,
    health,
    list_devices,
    participants,
    wait_for,
    watch,
)
from ._open import DeviceGone, NotANetworkCamera, NotReady, OpenError, Pyrealsense2Missing

__version__ = "0.1.0"

__all__ = [
    "Client",
    "DaemonNotRunning",
    "DeviceGone",
    "Endpoint",
    "Event",
    "HTTPError",
    "MalformedReply",
    "NotANetworkCamera",
    "NotFound",
    "NotReady",
    "OpenError",
    "PermissionDenied",
    "Pyrealsense2Missing",
    "RSDiscoveryError",
    "VersionMismatch",
    "Watcher",
    "describe_device",
    "domains",
    "get_device",
    "health",
    "list_devices",
    "participants",
    "wait_for",
    "watch",
]
