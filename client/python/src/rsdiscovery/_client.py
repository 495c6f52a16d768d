"""The client: HTTP over a Unix socket or TCP, Server-Sent Events, resumable watches."""
from __future__ import annotations

import codecs
import http.client
import json
import os
import queue
import socket
import threading
import time
import urllib.parse
from dataclasses import dataclass
from typing import Any, Callable, Dict, Iterator, List, Optional, Tuple

Device = Dict[str, Any]

__all__ = [
    "Client", "Endpoint", "Event", "Watcher", "RSDiscoveryError", "DaemonNotRunning", "PermissionDenied",
    "NotFound", "MalformedReply", "VersionMismatch", "HTTPError", "list_devices", "get_device", "domains",
    "health", "wait_for", "watch",
]


# ---- errors -----------------------------------------------------------------------------

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


class MalformedReply(RSDiscoveryError):
    """The daemon answered something the API does not promise."""


class VersionMismatch(RSDiscoveryError):
    """The daemon does not serve this client's API version (v1)."""


class HTTPError(RSDiscoveryError):
    """Any other unexpected HTTP status; ``status`` holds it."""

    def __init__(self, message: str, status: int) -> None:
        super().__init__(message)
        self.status = status


# ---- endpoint ---------------------------------------------------------------------------

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


def _check_filters(domain: Optional[int], product_line: Optional[str], source: Optional[str],
                   serial: Optional[str] = None, name: Optional[str] = None, address: Optional[str] = None) -> None:
    """Bad filter arguments are the caller's mistake: a ValueError at once, never a
    request the daemon would answer with 400 (or, worse, one that filters nothing)."""
    if domain is not None and (isinstance(domain, bool) or not isinstance(domain, int) or not 0 <= domain <= 232):
        raise ValueError(f"domain must be a DDS domain id, a whole number from 0 to 232, not {domain!r}")
    if product_line is not None and (not isinstance(product_line, str) or not product_line.strip()):
        raise ValueError(f"product_line must be a non-empty string such as 'D400', not {product_line!r}")
    if source is not None and (not isinstance(source, str) or source.lower() not in ("dds", "usb")):
        raise ValueError(f"source must be 'dds' or 'usb', not {source!r}")
    for key, value in (("serial", serial), ("name", name), ("address", address)):
        if value is not None and (not isinstance(value, str) or not value.strip()):
            raise ValueError(f"{key} must be a non-empty string, not {value!r}")


def _check_seconds(name: str, value: Any, allow_zero: bool = True) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0 or (value == 0 and not allow_zero):
        raise ValueError(f"{name} must be a number of seconds {'>= 0' if allow_zero else '> 0'}, not {value!r}")


def _query(domain: Optional[int], product_line: Optional[str], source: Optional[str],
           serial: Optional[str] = None, name: Optional[str] = None, address: Optional[str] = None) -> str:
    """The filters as the daemon takes them (it filters; the package never filters again)."""
    _check_filters(domain, product_line, source, serial, name, address)
    q: List[Tuple[str, str]] = []
    if domain is not None:
        q.append(("domain", str(domain)))
    for key, value in (("product-line", product_line), ("source", source), ("serial", serial), ("name", name),
                       ("address", address)):
        if value:
            q.append((key, value))
    return ("?" + urllib.parse.urlencode(q)) if q else ""


_NOT_NEWS = ("last-seen", "first-seen")


def _same(a: Device, b: Device) -> bool:
    """Equal apart from last-seen, which moves without being news, and first-seen, which a
    restarted daemon sets anew for a camera that never went away."""
    return {k: v for k, v in a.items() if k not in _NOT_NEWS} == {k: v for k, v in b.items() if k not in _NOT_NEWS}


def _complete(doc: Dict[str, Any]) -> bool:
    """Whether an answer says the daemon's first discovery is over. One without the field
    (a daemon older than it) has nothing to wait for."""
    return doc.get("complete") is not False


# How often an answer from an incomplete table is asked again, in seconds. The first
# discovery ends a few seconds after the daemon starts, at no moment a client can know.
_COMPLETE_POLL = 0.05


class _Closed(RSDiscoveryError):
    """The watch was closed while it waited; never reaches the caller."""


# ---- events -----------------------------------------------------------------------------

@dataclass
class Event:
    """One change of the device table.

    ``type`` is ``added``, ``changed`` or ``removed``; ``id`` the daemon's event id (its
    generation); ``synthetic`` is true for events this package derived from a re-list
    (after a daemon restart) rather than received; ``device`` the device document (for
    ``removed``, as last seen).
    """

    type: str
    id: int
    device: Device
    synthetic: bool = False


# What is read from the daemon at most, so that an endpoint that is not the daemon (or a
# broken one) cannot make a client allocate without bound: a whole reply, and one event of
# the stream. The daemon's largest answers are far below (1,000 devices: about 0.5 MB).
_MAX_REPLY = 64 << 20
_MAX_EVENT = 16 << 20


class _SseParser:
    """Incremental Server-Sent Events parser of the stream's bytes (lines end in LF, CR or
    CRLF). The bytes are decoded as they come, so a character split between two reads is
    still one character."""

    def __init__(self) -> None:
        self._decoder = codecs.getincrementaldecoder("utf-8")("replace")
        self._buf = ""
        self._event = ""
        self._data: List[str] = []
        self._data_size = 0
        self._id: Optional[str] = None

    def feed(self, chunk: bytes) -> List[Tuple[str, str, Optional[str]]]:
        out: List[Tuple[str, str, Optional[str]]] = []
        self._buf += self._decoder.decode(chunk)
        while True:
            i = min((p for p in (self._buf.find("\n"), self._buf.find("\r")) if p >= 0), default=-1)
            if i < 0:
                break
            if self._buf[i] == "\r" and i + 1 == len(self._buf):
                break  # a CR at the end may be half of a CRLF: wait
            line = self._buf[:i]
            skip = 2 if self._buf[i] == "\r" and self._buf[i + 1:i + 2] == "\n" else 1
            self._buf = self._buf[i + skip:]
            if line == "":
                if self._data or self._event:
                    out.append((self._event or "message", "\n".join(self._data), self._id))
                self._event, self._data, self._id, self._data_size = "", [], None, 0
            elif line.startswith(":"):
                continue
            else:
                key, _, value = line.partition(":")
                if value.startswith(" "):
                    value = value[1:]
                if key == "event":
                    self._event = value
                elif key == "data":
                    self._data.append(value)
                    self._data_size += len(value)
                    if self._data_size > _MAX_EVENT:
                        raise self.too_large()
                elif key == "id" and "\0" not in value:
                    self._id = value
        if len(self._buf) > _MAX_EVENT:  # a line that does not end
            raise self.too_large()
        return out

    @staticmethod
    def too_large() -> MalformedReply:
        return MalformedReply(f"malformed event stream from rs-discoveryd: an event larger than "
                              f"{_MAX_EVENT >> 20} MiB (not read)")


_STOP = object()


class Watcher:
    """A running watch of the daemon's events, with a consistent view across reconnects.

    It lists the devices, then streams from the generation of that list, so nothing
    falls in between; after a disconnect it resumes with ``Last-Event-ID``, and when the
    daemon cannot fill the gap (it restarted) it re-lists and reports the difference as
    synthetic events. That re-list first waits (up to ``complete_timeout`` seconds) for the
    restarted daemon's first discovery to be over, so a camera there before and after the
    restart is not reported removed and added again. Iterate it, or call :meth:`next` with a timeout; :meth:`close` ends
    it (also as a context manager).
    """

    def __init__(self, client: "Client", initial: bool = False, last_event_id: Optional[int] = None,
                 reconnect: bool = True, idle_timeout: float = 60.0, max_reconnect_delay: float = 2.0,
                 domain: Optional[int] = None, product_line: Optional[str] = None,
                 source: Optional[str] = None, complete_timeout: float = 10.0, *, serial: Optional[str] = None,
                 name: Optional[str] = None, address: Optional[str] = None) -> None:
        _check_filters(domain, product_line, source, serial, name, address)
        _check_seconds("complete_timeout", complete_timeout)
        _check_seconds("idle_timeout", idle_timeout, allow_zero=False)
        if last_event_id is not None and (isinstance(last_event_id, bool) or not isinstance(last_event_id, int)
                                          or last_event_id < 0):
            raise ValueError(f"last_event_id must be an event id (a whole number >= 0), not {last_event_id!r}")
        self._client = client
        self._complete_timeout = complete_timeout
        # The generation of the last list: stream events up to it are in the view already.
        self._listed_at = 0
        self._filters = (domain, product_line, source, serial, name, address)
        self._initial = initial
        self._reconnect = reconnect
        self._idle = idle_timeout
        self._max_delay = max_reconnect_delay
        self._last_id: Optional[int] = last_event_id
        self._known: Dict[str, Device] = {}
        self._complete = False
        self._queue: "queue.Queue[Any]" = queue.Queue()
        self._closed = threading.Event()
        self._lock = threading.Lock()
        self._conn: Optional[http.client.HTTPConnection] = None
        self._ended = False
        self._started = threading.Event()
        self._start_error: Optional[BaseException] = None
        self._thread = threading.Thread(target=self._run, name="rsdiscovery-watch", daemon=True)
        self._thread.start()
        self._started.wait()
        if self._start_error is not None:
            self.close()
            raise self._start_error

    # -- public
    @property
    def last_event_id(self) -> Optional[int]:
        """The id to resume from in a later watch (``last_event_id=``)."""
        return self._last_id

    def devices(self) -> List[Device]:
        """The view as tracked now (matching the watch's filters)."""
        with self._lock:
            # The daemon filtered the list and the stream: the view holds matching devices only.
            return [dict(d) for d in self._known.values()]

    def next(self, timeout: Optional[float] = None) -> Optional[Event]:
        """The next event; ``None`` when ``timeout`` seconds pass first or the watch was closed.
        Raises the error that ended the watch, if one did."""
        if self._ended:
            return None
        try:
            item = self._queue.get(timeout=timeout)
        except queue.Empty:
            return None
        if item is _STOP:
            self._ended = True
            return None
        if isinstance(item, BaseException):
            self._ended = True
            raise item
        return item

    def __iter__(self) -> Iterator[Event]:
        return self

    def __next__(self) -> Event:
        e = self.next()
        if e is None:
            raise StopIteration
        return e

    def close(self) -> None:
        """Ends the watch; safe from any thread, and more than once."""
        self._closed.set()
        with self._lock:
            conn = self._conn
        if conn is not None and conn.sock is not None:
            try:
                conn.sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout=5)

    def __enter__(self) -> "Watcher":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # -- the thread
    def _emit(self, kind: str, doc: Device, ident: int, synthetic: bool) -> None:
        key = doc["id"]
        with self._lock:
            old = self._known.get(key)
            if kind == "removed":
                if old is None and self._complete:
                    return
                self._known.pop(key, None)
            else:
                if old is not None and _same(old, doc):
                    self._known[key] = doc
                    return
                kind = "changed" if old is not None else "added"
                self._known[key] = doc
        self._queue.put(Event(kind, ident, doc, synthetic))

    def _list_complete(self) -> Dict[str, Any]:
        # A daemon that has just (re)started answers at once, from a table lacking the
        # cameras it has not heard from yet: compared with the view, that list would
        # report them removed, then added again a moment later. Only a complete list
        # tells real differences; the wait is bounded by complete_timeout.
        deadline = time.monotonic() + max(self._complete_timeout or 0, 0)
        while True:
            reply = self._client._get_json("/v1/devices" + _query(*self._filters))
            left = deadline - time.monotonic()
            if _complete(reply) or left <= 0:
                return reply
            if self._closed.wait(min(left, _COMPLETE_POLL)):
                raise _Closed("the watch was closed")

    def _relist(self, emit: bool) -> Optional[int]:
        # Only a list that replaces a view (after a resync) needs the complete table; the
        # first is the starting point, and what arrives after it comes as events.
        if self._complete:
            reply = self._list_complete()
        else:
            reply = self._client._get_json("/v1/devices" + _query(*self._filters))
        devices = reply.get("devices")
        if not isinstance(devices, list) or not all(isinstance(d, dict) and isinstance(d.get("id"), str)
                                                    for d in devices):
            raise MalformedReply(f"malformed reply from rs-discoveryd at {self._client.endpoint}: "
                                 "/v1/devices has no list of devices")
        generation = reply.get("generation")
        generation = generation if isinstance(generation, int) and generation >= 0 else None
        fresh = {d["id"]: d for d in devices}
        with self._lock:
            if generation is not None:
                self._last_id = max(self._last_id or 0, generation)
                self._listed_at = generation
            at = self._last_id or 0
            if not emit:
                self._known = fresh
                self._complete = True
                return generation
            gone = [d for k, d in self._known.items() if k not in fresh]
            self._complete = True
        for d in gone:
            self._emit("removed", d, at, True)
        for d in fresh.values():
            self._emit("added", d, at, True)
        return generation

    def _handle(self, kind: str, data: str, ident: Optional[str]) -> None:
        num = int(ident) if ident is not None and ident.isdigit() else None
        if kind == "resync":
            self._last_id = num
            self._relist(True)
            return
        if kind == "hello":
            if num is not None:
                self._last_id = num
            return
        if kind not in ("added", "changed", "removed"):
            return
        try:
            doc = json.loads(data)
        except ValueError:
            doc = None
        if not isinstance(doc, dict) or not isinstance(doc.get("id"), str):
            raise MalformedReply(f"malformed event from rs-discoveryd at {self._client.endpoint}: "
                                 f"{kind!r} without a device document")
        if num is not None:
            if num <= self._listed_at:
                return  # in the view already: the list after a resync was taken after it
            self._last_id = num
        self._emit(kind, doc, num or 0, False)

    def _connect_once(self) -> bool:
        """One connection; returns whether it got as far as an open stream."""
        if self._last_id is None:  # nothing to resume from: list, then stream from that generation
            self._relist(self._complete or self._initial)
        headers = {"Accept": "text/event-stream"}
        if self._last_id is not None:
            headers["Last-Event-ID"] = str(self._last_id)
        conn = self._client._connection(self._idle)
        with self._lock:
            self._conn = conn
        try:
            try:
                conn.request("GET", "/v1/events" + _query(*self._filters), headers=headers)
                resp = conn.getresponse()
            except OSError as e:
                raise _connect_error(self._client.endpoint, e) from None
            if resp.status != 200:
                body = resp.read()
                raise self._client._status_error("/v1/events", resp.status, body)
            if self._last_id is None:  # a daemon whose list has no generation
                self._relist(self._complete or self._initial)
            self._started.set()
            parser = _SseParser()
            while not self._closed.is_set():
                try:
                    chunk = resp.read1(65536)
                except (OSError, http.client.HTTPException):
                    break  # the stream broke (or went idle): reconnect
                if not chunk:
                    break
                for kind, data, ident in parser.feed(chunk):
                    self._handle(kind, data, ident)
            return True
        finally:
            with self._lock:
                self._conn = None
            conn.close()

    def _run(self) -> None:
        delay = 0.1
        error: Optional[BaseException] = None
        while not self._closed.is_set():
            opened = False
            try:
                opened = self._connect_once()
                if self._closed.is_set():
                    break
                if not self._reconnect:
                    error = DaemonNotRunning(f"rs-discoveryd at {self._client.endpoint} ended the event stream")
                    break
            except BaseException as e:  # noqa: B902 - handed to the caller, never dropped
                if self._closed.is_set():
                    break
                if not self._started.is_set():
                    self._start_error = e
                    self._started.set()
                    return
                transient = isinstance(e, DaemonNotRunning) or (isinstance(e, HTTPError) and e.status >= 500)
                if not transient or not self._reconnect:
                    error = e
                    break
            if opened:
                delay = 0.1
            if self._closed.wait(delay):
                break
            delay = min(delay * 2, max(self._max_delay, 0.1))
        self._started.set()
        self._queue.put(error if error is not None else _STOP)


# ---- the client ---------------------------------------------------------------------------

class Client:
    """A connection to rs-discoveryd.

    ``endpoint``: ``unix:/path``, ``http://host:port`` or an :class:`Endpoint`; by default
    ``$RS_DISCOVERY_ENDPOINT``, else the daemon's default socket. ``timeout``: seconds for
    one request.

    ``complete_timeout``: :meth:`list_devices`, :meth:`get_device` and :meth:`wait_for`
    first wait up to this many seconds for the daemon to finish its first discovery (it
    takes a few seconds after the daemon starts), so that a camera that is there is never
    reported missing just because the daemon has not heard from it yet. ``0``: answer at
    once from whatever the table holds.
    """

    def __init__(self, endpoint: "Endpoint | str | None" = None, timeout: float = 10.0,
                 complete_timeout: float = 5.0) -> None:
        _check_seconds("timeout", timeout, allow_zero=False)
        _check_seconds("complete_timeout", complete_timeout)
        self.endpoint = _endpoint(endpoint)
        self.timeout = timeout
        self.complete_timeout = complete_timeout

    def _complete_deadline(self) -> float:
        return time.monotonic() + max(self.complete_timeout or 0, 0)

    def _get_complete_json(self, path: str, deadline: float) -> Dict[str, Any]:
        """GET ``path`` again until the answer says the table is complete, or ``deadline``."""
        while True:
            reply = self._get_json(path)
            left = deadline - time.monotonic()
            if _complete(reply) or left <= 0:
                return reply
            time.sleep(min(left, _COMPLETE_POLL))

    def _connection(self, timeout: float) -> http.client.HTTPConnection:
        if self.endpoint.path is not None:
            return _UnixConnection(self.endpoint.path, timeout)
        return http.client.HTTPConnection(self.endpoint.host, self.endpoint.port, timeout=timeout)

    def _request(self, path: str) -> Tuple[int, bytes]:
        status, _, body = self._request_with_headers(path, self.timeout)
        return status, body

    def _request_with_headers(self, path: str, timeout: float) -> Tuple[int, Dict[str, str], bytes]:
        """One GET: (status, lower-cased headers, body)."""
        conn = self._connection(timeout)
        try:
            conn.request("GET", path, headers={"Accept": "application/json"})
            resp = conn.getresponse()
            if resp.length is not None and resp.length > _MAX_REPLY:  # said at once: nothing of it is read
                raise self._too_large(path)
            body = resp.read(_MAX_REPLY + 1)
            if len(body) > _MAX_REPLY:
                raise self._too_large(path)
            return resp.status, {k.lower(): v for k, v in resp.getheaders()}, body
        except socket.timeout:
            raise RSDiscoveryError(f"rs-discoveryd at {self.endpoint} did not answer within {timeout:g}s") \
                from None
        except OSError as e:
            raise _connect_error(self.endpoint, e) from None
        except http.client.HTTPException as e:
            raise MalformedReply(f"malformed reply from rs-discoveryd at {self.endpoint}: {e}") from None
        finally:
            conn.close()

    def _too_large(self, path: str) -> MalformedReply:
        return MalformedReply(f"malformed reply from rs-discoveryd at {self.endpoint}: the answer to GET {path} "
                              f"is larger than {_MAX_REPLY >> 20} MiB (not read)")

    def _status_error(self, path: str, status: int, body: bytes) -> RSDiscoveryError:
        try:
            detail = json.loads(body).get("error", "")
        except (ValueError, AttributeError):
            detail = ""
        if status in (404, 405):
            return VersionMismatch(f"version mismatch: rs-discoveryd at {self.endpoint} does not serve GET {path} "
                                   f"(HTTP {status}); this client speaks API v1")
        return HTTPError(f"rs-discoveryd at {self.endpoint} answered HTTP {status} to GET {path}"
                         + (f": {detail}" if detail else ""), status)

    def _get_json(self, path: str) -> Dict[str, Any]:
        status, body = self._request(path)
        if status != 200:
            raise self._status_error(path, status, body)
        return self._json_object(path, body)

    def _json_object(self, path: str, body: bytes) -> Dict[str, Any]:
        try:
            doc = json.loads(body)
        except ValueError:
            doc = None
        if not isinstance(doc, dict):
            raise MalformedReply(f"malformed reply from rs-discoveryd at {self.endpoint}: GET {path} "
                                 "did not return a JSON object")
        return doc

    def list_devices(self, domain: Optional[int] = None, product_line: Optional[str] = None,
                     source: Optional[str] = None, *, serial: Optional[str] = None, name: Optional[str] = None,
                     address: Optional[str] = None) -> List[Device]:
        """The devices the daemon knows now, optionally filtered (DDS domain, product line,
        ``dds``/``usb``, serial, a part of the name, an address of the camera's server; the
        daemon filters, values in any case). Waits for the complete table first
        (``complete_timeout``)."""
        return self._list((domain, product_line, source, serial, name, address), self._complete_deadline())

    def _list(self, filters: Tuple[Any, ...], deadline: float) -> List[Device]:
        path = "/v1/devices" + _query(*filters)
        devices = self._get_complete_json(path, deadline).get("devices")
        if not isinstance(devices, list) or not all(isinstance(d, dict) and "id" in d for d in devices):
            raise MalformedReply(f"malformed reply from rs-discoveryd at {self.endpoint}: no list of devices")
        return devices

    def get_device(self, device_id: str) -> Device:
        """One device by its id, serial or topic-root (the daemon looks it up); raises
        :class:`NotFound` when there is none, or when a serial or topic-root names several
        (their ids in ``NotFound.ids``). While the daemon's first discovery runs, an absent
        device is waited for (``complete_timeout``)."""
        if not isinstance(device_id, str) or not device_id:
            raise ValueError(f"device_id must be a device's id, serial or topic-root, not {device_id!r}")
        path = "/v1/devices/" + urllib.parse.quote(device_id, safe="")
        deadline = self._complete_deadline()
        while True:
            status, body = self._request(path)
            if status != 404:
                break
            # Absent from an incomplete table: it may be a camera not heard from yet.
            try:
                doc = json.loads(body)
            except ValueError:
                doc = None
            left = deadline - time.monotonic()
            if not isinstance(doc, dict) or _complete(doc) or left <= 0:
                raise NotFound(f"no device {device_id!r} at rs-discoveryd ({self.endpoint})")
            time.sleep(min(left, _COMPLETE_POLL))
        if status == 409:
            reply = self._json_object(path, body)
            ids = [i for i in reply.get("ids") or [] if isinstance(i, str)]
            raise NotFound(str(reply.get("error") or f"{device_id!r} names several devices"), ids)
        if status != 200:
            raise self._status_error(path, status, body)
        doc = self._json_object(path, body)
        if "id" not in doc:
            raise MalformedReply(f"malformed reply from rs-discoveryd at {self.endpoint}: GET {path} "
                                 "returned a device without an id")
        return doc

    def describe_device(self, device_id: str, timeout: float = 35.0) -> Dict[str, Any]:
        """What a network camera can do (Camera Discovery), by id, serial or topic-root:
        ``{"streams": [...], "device-options": [...], "extrinsics": [...], "presets": [...]}``,
        each stream with its ``profiles`` (fps, format, width, height), ``default-profile``
        and ``options``, as the camera's realdds server declares them; the daemon asks the
        server without opening the camera. The first time for a camera that may take up to
        the daemon's describe timeout (30 s; ``timeout`` bounds the wait here). Raises
        :class:`NotFound` for no such camera or a USB-only one; :class:`HTTPError` (``status``
        409) for recovery firmware or a serial of several cameras, 504 when the server did not
        answer in time. A 503 (the daemon rebuilding its DDS participant) is asked again after
        its Retry-After."""
        if not isinstance(device_id, str) or not device_id:
            raise ValueError(f"device_id must be a device's id, serial or topic-root, not {device_id!r}")
        _check_seconds("timeout", timeout, allow_zero=False)
        path = "/v1/devices/" + urllib.parse.quote(device_id, safe="") + "/description"
        deadline = time.monotonic() + timeout
        while True:
            status, headers, body = self._request_with_headers(path, max(deadline - time.monotonic(), 0.001))
            if status == 200:
                return self._json_object(path, body)
            try:
                doc = json.loads(body)
                message = doc.get("error") if isinstance(doc, dict) else None
            except ValueError:
                message = None
            if status == 404:
                raise NotFound(message or f"no device {device_id!r} at rs-discoveryd ({self.endpoint})")
            retry = headers.get("retry-after", "")
            if status == 503 and retry.isdigit():
                again = time.monotonic() + min(max(int(retry), 1), 30)
                if again < deadline:
                    time.sleep(again - time.monotonic())
                    continue
            if status in (409, 503, 504):
                raise HTTPError(f"rs-discoveryd at {self.endpoint} cannot describe {device_id!r}: "
                                f"{message or 'HTTP %d' % status}", status)
            raise self._status_error(path, status, body)

    def domains(self) -> List[Dict[str, Any]]:
        """Per-domain status: state, participant GUID, devices, accepted and rejected messages."""
        doms = self._get_json("/v1/domains").get("domains")
        if not isinstance(doms, list):
            raise MalformedReply(f"malformed reply from rs-discoveryd at {self.endpoint}: no list of domains")
        return doms

    def participants(self, domain: Optional[int] = None, state: Optional[str] = None) -> List[Dict[str, Any]]:
        """Every DDS participant the daemon hears (``/v1/participants``): realdds servers,
        librealsense and ROS programs, other DDS tools, with ``vendor``, ``addresses``,
        ``devices``, ``state`` ("alive" or "gone") and more; alive ones first."""
        _check_filters(domain, None, None)
        if state is not None and (not isinstance(state, str) or state.lower() not in ("alive", "gone")):
            raise ValueError(f"state must be 'alive' or 'gone', not {state!r}")
        params = [("domain", str(domain))] if domain is not None else []
        params += [("state", state.lower())] if state is not None else []
        path = "/v1/participants" + ("?" + urllib.parse.urlencode(params) if params else "")
        found = self._get_json(path).get("participants")
        if not isinstance(found, list):
            raise MalformedReply(f"malformed reply from rs-discoveryd at {self.endpoint}: no list of participants")
        return found

    def health(self) -> Dict[str, Any]:
        """``{"status": "ok", "version": ..., "devices": N, "complete": true, ...}``; ``complete`` is
        false while the daemon's first discovery still runs (``devices`` is not final then)."""
        return self._get_json("/healthz")

    def watcher(self, **kwargs: Any) -> Watcher:
        """A :class:`Watcher` (pull with timeouts); keyword arguments as :meth:`watch`."""
        return Watcher(self, **kwargs)

    def watch(self, initial: bool = False, last_event_id: Optional[int] = None, reconnect: bool = True,
              domain: Optional[int] = None, product_line: Optional[str] = None,
              source: Optional[str] = None, complete_timeout: float = 10.0, *, serial: Optional[str] = None,
              name: Optional[str] = None, address: Optional[str] = None) -> Iterator[Event]:
        """A generator of :class:`Event` that runs until closed (``break`` out, or ``close()``).

        It resumes by itself after a disconnect or a daemon restart, reporting what
        changed meanwhile. ``initial``: first yield every present device as ``added``.
        ``last_event_id``: resume after an id saved from an earlier watch.
        ``complete_timeout``: after a daemon restart, the watch waits up to this many seconds
        for the restarted daemon's first discovery before comparing, so a camera there
        before and after the restart is not reported removed and added again.
        """
        w = Watcher(self, initial=initial, last_event_id=last_event_id, reconnect=reconnect, domain=domain,
                    product_line=product_line, source=source, complete_timeout=complete_timeout, serial=serial,
                    name=name, address=address)
        return _generate(w)

    def wait_for(self, predicate: Optional[Callable[[Device], bool]] = None, timeout: float = 10.0,
                 count: int = 1, domain: Optional[int] = None, product_line: Optional[str] = None,
                 source: Optional[str] = None, *, serial: Optional[str] = None, name: Optional[str] = None,
                 address: Optional[str] = None) -> Device:
        """Waits until ``count`` devices matching the filters and ``predicate`` are present;
        returns the first of them. Raises :class:`TimeoutError` (the built-in) when
        ``timeout`` seconds pass first. Like :meth:`list_devices` it looks at the complete
        table (bounded by ``complete_timeout`` and by ``timeout``)."""
        if predicate is not None and not callable(predicate):
            raise ValueError(f"predicate must be a function of a device, not {predicate!r}")
        _check_seconds("timeout", timeout)
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise ValueError(f"count must be a whole number >= 1, not {count!r}")
        filters = (domain, product_line, source, serial, name, address)
        _check_filters(*filters)

        def hit(devices: List[Device]) -> List[Device]:
            return [d for d in devices if predicate is None or predicate(d)]

        deadline = time.monotonic() + timeout
        complete_by = min(deadline, self._complete_deadline())
        now = hit(self._list(filters, complete_by))
        if len(now) >= count:
            return now[0]
        with Watcher(self, domain=domain, product_line=product_line, source=source,
                     complete_timeout=max(complete_by - time.monotonic(), 0), serial=serial, name=name,
                     address=address) as w:
            while True:
                now = hit(w.devices())
                if len(now) >= count:
                    return now[0]
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"{len(now)} of {count} device(s) present after {timeout} s "
                                       f"at rs-discoveryd ({self.endpoint})")
                w.next(timeout=left)


def _generate(w: Watcher) -> Iterator[Event]:
    try:
        while True:
            e = w.next()
            if e is None:
                return
            yield e
    finally:
        w.close()


# ---- module-level shortcuts ----------------------------------------------------------------

def list_devices(domain: Optional[int] = None, product_line: Optional[str] = None, source: Optional[str] = None,
                 endpoint: "Endpoint | str | None" = None, complete_timeout: float = 5.0, *,
                 serial: Optional[str] = None, name: Optional[str] = None,
                 address: Optional[str] = None) -> List[Device]:
    """The devices the daemon knows now (see :meth:`Client.list_devices`; ``complete_timeout=0``
    does not wait for the daemon's first discovery)."""
    return Client(endpoint, complete_timeout=complete_timeout).list_devices(domain, product_line, source,
                                                                            serial=serial, name=name,
                                                                            address=address)


def get_device(device_id: str, endpoint: "Endpoint | str | None" = None, complete_timeout: float = 5.0) -> Device:
    """One device by id; raises :class:`NotFound` (see :meth:`Client.get_device`)."""
    return Client(endpoint, complete_timeout=complete_timeout).get_device(device_id)


def describe_device(device_id: str, endpoint: "Endpoint | str | None" = None, timeout: float = 35.0) -> Dict[str, Any]:
    """What a network camera can do (see :meth:`Client.describe_device`)."""
    return Client(endpoint).describe_device(device_id, timeout)


def domains(endpoint: "Endpoint | str | None" = None) -> List[Dict[str, Any]]:
    """Per-domain status (see :meth:`Client.domains`)."""
    return Client(endpoint).domains()


def participants(domain: Optional[int] = None, state: Optional[str] = None,
                 endpoint: "Endpoint | str | None" = None) -> List[Dict[str, Any]]:
    """Every DDS participant the daemon hears (see :meth:`Client.participants`)."""
    return Client(endpoint).participants(domain, state)


def health(endpoint: "Endpoint | str | None" = None) -> Dict[str, Any]:
    """The daemon's /healthz."""
    return Client(endpoint).health()


def wait_for(predicate: Optional[Callable[[Device], bool]] = None, timeout: float = 10.0, count: int = 1,
             domain: Optional[int] = None, product_line: Optional[str] = None, source: Optional[str] = None,
             endpoint: "Endpoint | str | None" = None, complete_timeout: float = 5.0, *,
             serial: Optional[str] = None, name: Optional[str] = None, address: Optional[str] = None) -> Device:
    """Waits for a device; raises :class:`TimeoutError` (see :meth:`Client.wait_for`)."""
    return Client(endpoint, complete_timeout=complete_timeout).wait_for(predicate, timeout, count, domain,
                                                                        product_line, source, serial=serial,
                                                                        name=name, address=address)


def watch(initial: bool = False, last_event_id: Optional[int] = None, reconnect: bool = True,
          domain: Optional[int] = None, product_line: Optional[str] = None, source: Optional[str] = None,
          endpoint: "Endpoint | str | None" = None, complete_timeout: float = 10.0, *,
          serial: Optional[str] = None, name: Optional[str] = None, address: Optional[str] = None) -> Iterator[Event]:
    """A resumable generator of events (see :meth:`Client.watch`)."""
    return Client(endpoint).watch(initial, last_event_id, reconnect, domain, product_line, source,
                                  complete_timeout, serial=serial, name=name, address=address)
