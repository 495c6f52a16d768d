"""Watching the daemon's events: the Server-Sent Events parser and Watcher, which keeps a
consistent view across reconnects and daemon restarts."""
from __future__ import annotations

import codecs
import http.client
import json
import queue
import socket
import threading
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Dict, Iterator, List, Optional, Tuple

from ._endpoint import _connect_error
from ._errors import DaemonNotRunning, HTTPError, MalformedReply, RSDiscoveryError
from ._model import Device
from ._query import _COMPLETE_POLL, Domains, _check_filters, _check_seconds, _complete, _domains, _query, _same

if TYPE_CHECKING:
    from ._client import Client


class _Closed(RSDiscoveryError):
    """The watch was closed while it waited; never reaches the caller."""


# ---- events -----------------------------------------------------------------------------

@dataclass(frozen=True)
class Event:
    """One change of the device table.

    ``type`` is ``added``, ``changed`` or ``removed``; ``id`` the daemon's event id (its
    generation); ``synthetic`` is true for events this package derived from a re-list
    (after a daemon restart) rather than received; ``device`` the :class:`Device` (for
    ``removed``, as last seen).
    """

    type: str
    id: int
    device: Device
    synthetic: bool = False


# One event of the stream is read up to this size at most, so that an endpoint that is not
# the daemon (or a broken one) cannot make a client allocate without bound.
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
                 domain: Domains = None, product_line: Optional[str] = None,
                 source: Optional[str] = None, complete_timeout: float = 10.0, *, serial: Optional[str] = None,
                 name: Optional[str] = None, address: Optional[str] = None, host: Optional[str] = None,
                 in_use: Optional[bool] = None) -> None:
        # The domains once: an iterator given as domain= would be empty at the second request.
        domain = _domains(domain) or None
        _check_filters(domain, product_line, source, serial, name, address, host, in_use)
        _check_seconds("complete_timeout", complete_timeout)
        _check_seconds("idle_timeout", idle_timeout, allow_zero=False)
        if last_event_id is not None and (isinstance(last_event_id, bool) or not isinstance(last_event_id, int)
                                          or last_event_id < 0):
            raise ValueError(f"last_event_id must be an event id (a whole number >= 0), not {last_event_id!r}")
        self._client = client
        self._complete_timeout = complete_timeout
        # The generation of the last list: stream events up to it are in the view already.
        self._listed_at = 0
        self._filters = (domain, product_line, source, serial, name, address, host, in_use)
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
        client._track(self)  # so that closing the client closes its watches
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
            return list(self._known.values())

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
        event: Event = item
        return event

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
        self._client._untrack(self)
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
        key = doc.id
        with self._lock:
            old = self._known.get(key)
            if kind == "removed":
                if old is None and self._complete:
                    return
                self._known.pop(key, None)
            else:
                if old is not None and _same(old.raw, doc.raw):
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
        fresh = {d.id: d for d in map(Device.from_json, devices)}
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
        device = Device.from_json(doc)
        if num is not None:
            if num <= self._listed_at:
                return  # in the view already: the list after a resync was taken after it
            self._last_id = num
        self._emit(kind, device, num or 0, False)

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


def _generate(w: Watcher) -> Iterator[Event]:
    try:
        while True:
            e = w.next()
            if e is None:
                return
            yield e
    finally:
        w.close()

