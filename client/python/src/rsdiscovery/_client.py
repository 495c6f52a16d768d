"""The client: HTTP over a Unix socket or TCP, the API's documents as typed objects, and
resumable watches (the parts live in _endpoint, _query, _model and _watch)."""
from __future__ import annotations

import http.client
import json
import socket
import threading
import time
import urllib.parse
import weakref
from typing import Any, Callable, Dict, Iterator, List, Optional, Tuple

from ._expected import Expected, wait as _wait
from ._endpoint import Endpoint, _connect_error, _endpoint, _UnixConnection
from ._errors import (DaemonNotRunning, Gone, HTTPError, MalformedReply, NotFound, PermissionDenied,
                      RSDiscoveryError, VersionMismatch)
from ._history import DeviceHistory, GoneDevice, History
from ._model import Device, DeviceClients, DomainStatus, Health, Participant
from ._query import _COMPLETE_POLL, Domains, _check_filters, _check_seconds, _complete, _domains, _query
from ._watch import Event, Watcher, _generate

__all__ = [
    "Client", "Endpoint", "Event", "Watcher", "RSDiscoveryError", "DaemonNotRunning", "PermissionDenied",
    "NotFound", "Gone", "MalformedReply", "VersionMismatch", "HTTPError", "list_devices", "get_device", "domains",
    "health", "wait_for", "watch",
]

# What is read from the daemon at most, so that an endpoint that is not the daemon (or a
# broken one) cannot make a client allocate without bound. The daemon's largest answers
# are far below (1,000 devices: about 0.5 MB).
_MAX_REPLY = 64 << 20


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

    Each request is a connection of its own; what stays open are the watches (:meth:`watch`,
    :meth:`watcher`, :meth:`wait_for` while it waits). :meth:`close`, or leaving a ``with
    Client(...) as client:`` block, ends every watch made through the client that still
    runs, and a request after it raises :class:`RSDiscoveryError`.
    """

    def __init__(self, endpoint: "Endpoint | str | None" = None, timeout: float = 10.0,
                 complete_timeout: float = 5.0) -> None:
        _check_seconds("timeout", timeout, allow_zero=False)
        _check_seconds("complete_timeout", complete_timeout)
        self.endpoint = _endpoint(endpoint)
        self.timeout = timeout
        self.complete_timeout = complete_timeout
        self._lock = threading.Lock()
        self._watchers: "weakref.WeakSet[Watcher]" = weakref.WeakSet()
        self._closed = False

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self._closed

    def close(self) -> None:
        """Ends every watch made through this client that still runs (their iterators and
        generators end, their connections close); later requests raise. Safe more than once."""
        with self._lock:
            self._closed = True
            running = list(self._watchers)
            self._watchers.clear()
        for w in running:
            w.close()

    def _track(self, w: Watcher) -> None:
        with self._lock:
            if self._closed:
                raise RSDiscoveryError(f"this client of rs-discoveryd at {self.endpoint} is closed")
            self._watchers.add(w)

    def _untrack(self, w: Watcher) -> None:
        with self._lock:
            self._watchers.discard(w)

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
        if self._closed:
            raise RSDiscoveryError(f"this client of rs-discoveryd at {self.endpoint} is closed")
        if self.endpoint.path is not None:
            return _UnixConnection(self.endpoint.path, timeout)
        return http.client.HTTPConnection(self.endpoint.host or "", self.endpoint.port, timeout=timeout)

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
            if not self._is_rs_discoveryd():
                return VersionMismatch(f"something other than rs-discoveryd answers at {self.endpoint}: GET {path} "
                                       f"got HTTP {status}, and it has no rs-discoveryd /healthz; is the endpoint "
                                       "right?")
            return VersionMismatch(f"version mismatch: rs-discoveryd at {self.endpoint} does not serve GET {path} "
                                   f"(HTTP {status}); this client speaks API v1")
        return HTTPError(f"rs-discoveryd at {self.endpoint} answered HTTP {status} to GET {path}"
                         + (f": {detail}" if detail else ""), status)

    def _is_rs_discoveryd(self) -> bool:
        """Whether what answers has rs-discoveryd's /healthz (a version), as the C++ client asks."""
        try:
            status, body = self._request("/healthz")
            doc = json.loads(body) if status == 200 else None
        except (RSDiscoveryError, ValueError):
            return False
        return isinstance(doc, dict) and isinstance(doc.get("version"), str)

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

    def list_devices(self, domain: Domains = None, product_line: Optional[str] = None,
                     source: Optional[str] = None, *, serial: Optional[str] = None, name: Optional[str] = None,
                     address: Optional[str] = None, host: Optional[str] = None,
                     in_use: Optional[bool] = None) -> List[Device]:
        """The devices the daemon knows now, as :class:`Device`, optionally filtered: DDS
        ``domain`` (one id, or several: ``domain=[1, 2]``, as ``rs-discover list -d 1 -d 2``),
        product line, ``dds``/``usb``/``remote-usb``, serial, a part of the name, an address of
        the camera's server (or of the host sharing it), ``host``: the USB cameras the daemon
        on the host of this name shares (remote-usb, :attr:`Device.host`), ``in_use``: network
        cameras with a client (True) or every other device (False, see :meth:`clients`); the
        daemon filters, values in any case. Waits for the complete table first
        (``complete_timeout``)."""
        return self._list((domain, product_line, source, serial, name, address, host, in_use),
                          self._complete_deadline())

    def _list(self, filters: Tuple[Any, ...], deadline: float) -> List[Device]:
        path = "/v1/devices" + _query(*filters)
        devices = self._get_complete_json(path, deadline).get("devices")
        if not isinstance(devices, list):
            raise MalformedReply(f"malformed reply from rs-discoveryd at {self.endpoint}: no list of devices")
        return [Device.from_json(d) for d in devices]

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
        if status == 410:
            reply = self._json_object(path, body)
            raise Gone(str(reply.get("error") or f"{device_id!r} is gone"), GoneDevice.from_json(reply.get("gone")))
        if status != 200:
            raise self._status_error(path, status, body)
        return Device.from_json(self._json_object(path, body))

    def device_history(self, device_id: str) -> DeviceHistory:
        """One camera's history by id, serial or topic-root, present or gone: its latest
        changes (added: new or back; removed: why), its removals by reason, and, when it
        left, its :class:`GoneDevice`. Raises :class:`NotFound` for a camera never seen."""
        if not isinstance(device_id, str) or not device_id:
            raise ValueError(f"device_id must be a device's id, serial or topic-root, not {device_id!r}")
        path = "/v1/devices/" + urllib.parse.quote(device_id, safe="") + "/history"
        status, body = self._request(path)
        if status == 404:
            raise NotFound(f"no device {device_id!r} was ever seen by rs-discoveryd ({self.endpoint})")
        if status != 200:
            raise self._status_error(path, status, body)
        return DeviceHistory.from_json(self._json_object(path, body))

    def history(self, since: int = 0, limit: Optional[int] = None) -> History:
        """Every camera's presence changes after generation ``since``, oldest first (at most
        ``limit``; the daemon's default is 1000); page on with ``since=page.next``."""
        if isinstance(since, bool) or not isinstance(since, int) or since < 0:
            raise ValueError(f"since must be a generation (an integer >= 0), not {since!r}")
        path = f"/v1/history?since={since}" + (f"&limit={int(limit)}" if limit is not None else "")
        return History.from_json(self._get_json(path))

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

    def domains(self) -> List[DomainStatus]:
        """Every DDS domain the daemon joined, as a :class:`DomainStatus`: its state, the
        daemon's participant GUID, devices, accepted and rejected messages."""
        doms = self._get_json("/v1/domains").get("domains")
        if not isinstance(doms, list):
            raise MalformedReply(f"malformed reply from rs-discoveryd at {self.endpoint}: no list of domains")
        return [DomainStatus.from_json(d) for d in doms]

    def clients(self, device: "Device | str") -> DeviceClients:
        """Who uses a network camera (``GET /v1/devices/{id}/clients``), given as a
        :class:`Device` or its id, serial or topic-root: its clients (DDS participants
        other than its server on its topics, with the streams each reads) and the streams
        read now. Raises :class:`NotFound` for no such camera or a USB one (the daemon
        cannot see processes: ``rs-discover clients`` looks for them)."""
        key = device.id if isinstance(device, Device) else device
        if not isinstance(key, str) or not key:
            raise ValueError(f"device must be a Device or a device's id, serial or topic-root, not {device!r}")
        path = "/v1/devices/" + urllib.parse.quote(key, safe="") + "/clients"
        status, body = self._request(path)
        if status == 404:
            try:
                detail = json.loads(body).get("error", "")
            except (ValueError, AttributeError):
                detail = ""
            raise NotFound(detail or f"no device with id {key!r}")
        if status != 200:
            raise self._status_error(path, status, body)
        return DeviceClients.from_json(self._json_object(path, body))

    def participants(self, domain: Domains = None, state: Optional[str] = "alive") -> List[Participant]:
        """The DDS participants the daemon hears (``/v1/participants``), as
        :class:`Participant`: realdds servers, librealsense and ROS programs, other DDS tools.
        Like ``rs-discover participants``, only those alive now unless asked: ``state`` is
        ``"alive"`` (the default), ``"gone"`` (the latest 256 per domain that went), or None
        (or ``"all"``) for both, alive ones first. ``domain``: one DDS domain or several."""
        if state is not None and (not isinstance(state, str) or state.lower() not in ("alive", "gone", "all")):
            raise ValueError(f"state must be 'alive', 'gone' or 'all' (or None), not {state!r}")
        params = [("domain", str(d)) for d in _domains(domain)]
        params += [("state", state.lower())] if state is not None and state.lower() != "all" else []
        path = "/v1/participants" + ("?" + urllib.parse.urlencode(params) if params else "")
        found = self._get_json(path).get("participants")
        if not isinstance(found, list):
            raise MalformedReply(f"malformed reply from rs-discoveryd at {self.endpoint}: no list of participants")
        return [Participant.from_json(p) for p in found]

    def health(self) -> Health:
        """The daemon's ``/healthz`` as a :class:`Health`: ``status`` "ok", ``version``,
        ``devices``, ``complete`` (false while the daemon's first discovery still runs:
        ``devices`` is not final then), ``usb``."""
        return Health.from_json(self._get_json("/healthz"))

    def expected(self) -> Expected:
        """The cameras the daemon's configuration expects (``GET /v1/expected``), present and
        missing. A daemon older than the route raises :class:`NotFound`."""
        return Expected.from_json(self._get_json("/v1/expected"))

    def wait(self, *keys: str, expected: bool = False, timeout: float = 30.0) -> List[Device]:
        """Waits until every camera named in ``keys`` (id, serial or topic-root) and, with
        ``expected``, every camera the daemon expects is listed; returns their devices, in
        that order. It follows the event stream: it returns as soon as the last one is
        there. Raises :class:`WaitTimeout` (a :class:`TimeoutError`) naming the missing ones,
        with what the daemon knows of why, when ``timeout`` seconds pass first."""
        _check_seconds("timeout", timeout)
        if not keys and not expected:
            raise ValueError("name the cameras to wait for, or pass expected=True")
        if not all(isinstance(k, str) and k for k in keys):
            raise ValueError(f"cameras are named by id, serial or topic-root strings, not {keys!r}")
        return _wait(self, keys, expected, timeout)

    def watcher(self, **kwargs: Any) -> Watcher:
        """A :class:`Watcher` (pull with timeouts); keyword arguments as :meth:`watch`."""
        return Watcher(self, **kwargs)

    def watch(self, initial: bool = False, last_event_id: Optional[int] = None, reconnect: bool = True,
              domain: Domains = None, product_line: Optional[str] = None,
              source: Optional[str] = None, complete_timeout: float = 10.0, *, serial: Optional[str] = None,
              name: Optional[str] = None, address: Optional[str] = None,
              host: Optional[str] = None, in_use: Optional[bool] = None) -> Iterator[Event]:
        """A generator of :class:`Event` that runs until closed (``break`` out, or ``close()``).

        It resumes by itself after a disconnect or a daemon restart, reporting what
        changed meanwhile. ``initial``: first yield every present device as ``added``.
        ``last_event_id``: resume after an id saved from an earlier watch.
        ``complete_timeout``: after a daemon restart, the watch waits up to this many seconds
        for the restarted daemon's first discovery before comparing, so a camera there
        before and after the restart is not reported removed and added again. The filters
        are :meth:`list_devices`'; with ``in_use``, a camera a client comes to is ``added``
        and ``removed`` when its last client goes (True), the other way round (False).
        """
        w = Watcher(self, initial=initial, last_event_id=last_event_id, reconnect=reconnect, domain=domain,
                    product_line=product_line, source=source, complete_timeout=complete_timeout, serial=serial,
                    name=name, address=address, host=host, in_use=in_use)
        return _generate(w)

    def wait_for(self, predicate: Optional[Callable[[Device], bool]] = None, timeout: float = 10.0,
                 count: int = 1, domain: Domains = None, product_line: Optional[str] = None,
                 source: Optional[str] = None, *, serial: Optional[str] = None, name: Optional[str] = None,
                 address: Optional[str] = None, host: Optional[str] = None,
                 in_use: Optional[bool] = None) -> Device:
        """Waits until ``count`` devices matching the filters and ``predicate`` are present;
        returns the first of them. Raises :class:`TimeoutError` (the built-in) when
        ``timeout`` seconds pass first. Like :meth:`list_devices` it looks at the complete
        table (bounded by ``complete_timeout`` and by ``timeout``)."""
        if predicate is not None and not callable(predicate):
            raise ValueError(f"predicate must be a function of a device, not {predicate!r}")
        _check_seconds("timeout", timeout)
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise ValueError(f"count must be a whole number >= 1, not {count!r}")
        domain = _domains(domain) or None  # once: an iterator is empty the second time
        filters = (domain, product_line, source, serial, name, address, host, in_use)
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
                     address=address, host=host, in_use=in_use) as w:
            while True:
                now = hit(w.devices())
                if len(now) >= count:
                    return now[0]
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"{len(now)} of {count} device(s) present after {timeout} s "
                                       f"at rs-discoveryd ({self.endpoint})")
                w.next(timeout=left)


# ---- module-level shortcuts ----------------------------------------------------------------

def list_devices(domain: Domains = None, product_line: Optional[str] = None, source: Optional[str] = None,
                 endpoint: "Endpoint | str | None" = None, complete_timeout: float = 5.0, *,
                 serial: Optional[str] = None, name: Optional[str] = None,
                 address: Optional[str] = None, host: Optional[str] = None,
                 in_use: Optional[bool] = None) -> List[Device]:
    """The devices the daemon knows now (see :meth:`Client.list_devices`; ``complete_timeout=0``
    does not wait for the daemon's first discovery)."""
    return Client(endpoint, complete_timeout=complete_timeout).list_devices(domain, product_line, source,
                                                                            serial=serial, name=name,
                                                                            address=address, host=host,
                                                                            in_use=in_use)


def get_device(device_id: str, endpoint: "Endpoint | str | None" = None, complete_timeout: float = 5.0) -> Device:
    """One device by id; raises :class:`NotFound` (see :meth:`Client.get_device`)."""
    return Client(endpoint, complete_timeout=complete_timeout).get_device(device_id)


def describe_device(device_id: str, endpoint: "Endpoint | str | None" = None, timeout: float = 35.0) -> Dict[str, Any]:
    """What a network camera can do (see :meth:`Client.describe_device`)."""
    return Client(endpoint).describe_device(device_id, timeout)


def domains(endpoint: "Endpoint | str | None" = None) -> List[DomainStatus]:
    """Per-domain status (see :meth:`Client.domains`)."""
    return Client(endpoint).domains()


def participants(domain: Domains = None, state: Optional[str] = "alive",
                 endpoint: "Endpoint | str | None" = None) -> List[Participant]:
    """The DDS participants the daemon hears, alive ones unless ``state`` says otherwise
    (see :meth:`Client.participants`)."""
    return Client(endpoint).participants(domain, state)


def health(endpoint: "Endpoint | str | None" = None) -> Health:
    """The daemon's /healthz."""
    return Client(endpoint).health()


def wait_for(predicate: Optional[Callable[[Device], bool]] = None, timeout: float = 10.0, count: int = 1,
             domain: Domains = None, product_line: Optional[str] = None, source: Optional[str] = None,
             endpoint: "Endpoint | str | None" = None, complete_timeout: float = 5.0, *,
             serial: Optional[str] = None, name: Optional[str] = None, address: Optional[str] = None,
             host: Optional[str] = None, in_use: Optional[bool] = None) -> Device:
    """Waits for a device; raises :class:`TimeoutError` (see :meth:`Client.wait_for`)."""
    return Client(endpoint, complete_timeout=complete_timeout).wait_for(predicate, timeout, count, domain,
                                                                        product_line, source, serial=serial,
                                                                        name=name, address=address, host=host,
                                                                        in_use=in_use)


def watch(initial: bool = False, last_event_id: Optional[int] = None, reconnect: bool = True,
          domain: Domains = None, product_line: Optional[str] = None, source: Optional[str] = None,
          endpoint: "Endpoint | str | None" = None, complete_timeout: float = 10.0, *,
          serial: Optional[str] = None, name: Optional[str] = None, address: Optional[str] = None,
          host: Optional[str] = None, in_use: Optional[bool] = None) -> Iterator[Event]:
    """A resumable generator of events (see :meth:`Client.watch`)."""
    return Client(endpoint).watch(initial, last_event_id, reconnect, domain, product_line, source,
                                  complete_timeout, serial=serial, name=name, address=address, host=host,
                                  in_use=in_use)
