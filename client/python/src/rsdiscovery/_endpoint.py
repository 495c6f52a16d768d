"""Where the daemon is (Endpoint) and how one HTTP connection to it is made."""
from __future__ import annotations

import http.client
import os
import socket
import urllib.parse
from dataclasses import dataclass
from typing import Optional

from ._errors import DaemonNotRunning, PermissionDenied, RSDiscoveryError

_HINT = "is rs-discoveryd running? Give another endpoint with endpoint= or RS_DISCOVERY_ENDPOINT"


@dataclass(frozen=True)
class Endpoint:
    """Where the daemon is: a Unix socket path, or an HTTP host and port."""

    path: Optional[str] = None
    host: Optional[str] = None
    port: int = 0

    @staticmethod
    def parse(text: str) -> "Endpoint":
        """``unix:/run/x.sock``, ``unix:///run/x.sock``, ``/run/x.sock`` or ``http://host:port``."""
        if text.startswith("unix:") or text.startswith("/"):
            path = text[5:] if text.startswith("unix:") else text
            if path.startswith("//"):
                path = path[2:]
            if not path.startswith("/"):
                raise ValueError(f"bad endpoint {text!r}: the socket path must be absolute")
            return Endpoint(path=path)
        if text.startswith("http://"):
            u = urllib.parse.urlsplit(text)
            if u.path not in ("", "/") or not u.hostname:
                raise ValueError(f"bad endpoint {text!r}: expected http://host:port")
            try:
                port = u.port or 80
            except ValueError:
                raise ValueError(f"bad endpoint {text!r}: bad port") from None
            return Endpoint(host=u.hostname, port=port)
        raise ValueError(f"bad endpoint {text!r}: expected unix:/path/to/socket or http://host:port")

    @staticmethod
    def default_socket() -> "Endpoint":
        """The daemon's default socket, by the daemon's own rule (proto/model/socket_path.cpp,
        which this mirrors; the tests check that they agree): $RUNTIME_DIRECTORY/api.sock,
        /run/rs-discoveryd/api.sock for root, else $XDG_RUNTIME_DIR/rs-discoveryd.sock, else
        /tmp/rs-discoveryd-UID.sock (or, when that does not exist, the system service's
        /run/rs-discoveryd/api.sock if it does)."""
        runtime = os.environ.get("RUNTIME_DIRECTORY")
        if runtime:
            return Endpoint(path=runtime.split(":")[0] + "/api.sock")
        if os.geteuid() == 0:
            return Endpoint(path=_SYSTEM_SOCKET)
        xdg = os.environ.get("XDG_RUNTIME_DIR")
        own = xdg + "/rs-discoveryd.sock" if xdg else f"/tmp/rs-discoveryd-{os.geteuid()}.sock"
        # A user with no daemon of their own asks the system's service.
        if not os.path.exists(own) and os.path.exists(_SYSTEM_SOCKET):
            return Endpoint(path=_SYSTEM_SOCKET)
        return Endpoint(path=own)

    @staticmethod
    def from_environment() -> "Endpoint":
        """$RS_DISCOVERY_ENDPOINT when set, else :meth:`default_socket`."""
        text = os.environ.get("RS_DISCOVERY_ENDPOINT")
        return Endpoint.parse(text) if text else Endpoint.default_socket()

    def __str__(self) -> str:
        if self.path is not None:
            return "unix:" + self.path
        host = f"[{self.host}]" if self.host and ":" in self.host else self.host
        return f"http://{host}:{self.port}"


_SYSTEM_SOCKET = "/run/rs-discoveryd/api.sock"


def _endpoint(value: "Endpoint | str | None") -> Endpoint:
    if value is None or value == "":
        return Endpoint.from_environment()
    if isinstance(value, Endpoint):
        return value
    return Endpoint.parse(value)


class _UnixConnection(http.client.HTTPConnection):
    def __init__(self, path: str, timeout: float) -> None:
        super().__init__("localhost", timeout=timeout)
        self._path = path

    def connect(self) -> None:
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        s.settimeout(self.timeout)
        try:
            s.connect(self._path)
        except BaseException:
            s.close()
            raise
        self.sock = s


def _connect_error(ep: Endpoint, exc: OSError) -> RSDiscoveryError:
    where = ep.path if ep.path is not None else str(ep)
    if isinstance(exc, FileNotFoundError) or isinstance(exc, NotADirectoryError):
        return DaemonNotRunning(f"cannot reach rs-discoveryd: no socket at {where} ({_HINT})")
    if isinstance(exc, ConnectionRefusedError):
        stale = " (a stale socket file)" if ep.path is not None else ""
        return DaemonNotRunning(f"cannot reach rs-discoveryd: nothing listens on {where}{stale} ({_HINT})")
    if isinstance(exc, PermissionError):
        return PermissionDenied(f"permission denied on {where}: this user may not connect to the daemon's "
                                "socket (join the group that owns it, or ask the administrator)")
    if isinstance(exc, socket.timeout):
        return DaemonNotRunning(f"rs-discoveryd at {ep} did not answer in time")
    return DaemonNotRunning(f"cannot reach rs-discoveryd at {where}: {exc}")

