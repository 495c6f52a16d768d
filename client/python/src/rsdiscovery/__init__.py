"""Client of rs-discoveryd, the daemon that keeps a live table of Intel RealSense cameras.

Devices are the daemon's JSON documents as dicts (every field verbatim: ``id``, ``name``,
``serial``, ``domain``, ``topic-root``, ``server`` ...). Standard library only.
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

__version__ = "0.1.0"

__all__ = [
    "Client",
    "DaemonNotRunning",
    "Endpoint",
    "Event",
    "HTTPError",
    "MalformedReply",
    "NotFound",
    "PermissionDenied",
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
