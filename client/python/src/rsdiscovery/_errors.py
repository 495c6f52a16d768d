"""The package's errors: every one a subclass of RSDiscoveryError."""
from __future__ import annotations

from typing import Any, List, Optional


class RSDiscoveryError(Exception):
    """Base of every error this package raises."""


class DaemonNotRunning(RSDiscoveryError):
    """Nothing answers at the endpoint (the message names the socket or address tried)."""


class PermissionDenied(RSDiscoveryError):
    """The daemon's socket exists but this user may not connect to it."""


class NotFound(RSDiscoveryError):
    """No device with that id, serial or topic-root; or (``ids`` set) a serial or
    topic-root that names several devices, whose ids are listed."""

    def __init__(self, message: str, ids: Optional[List[str]] = None) -> None:
        super().__init__(message)
        self.ids = ids or []


class Gone(NotFound):
    """The camera was here and left (the daemon answered 410): ``gone`` (a
    :class:`GoneDevice`) says why, when, and what it was. A camera never seen is a plain
    :class:`NotFound`."""

    def __init__(self, message: str, gone: Any) -> None:
        super().__init__(message)
        self.gone = gone


class MalformedReply(RSDiscoveryError):
    """The daemon answered something the API does not promise."""


class VersionMismatch(RSDiscoveryError):
    """The daemon does not serve this client's API version (v1)."""


class HTTPError(RSDiscoveryError):
    """Any other unexpected HTTP status; ``status`` holds it."""

    def __init__(self, message: str, status: int) -> None:
        super().__init__(message)
        self.status = status

