"""Open a network camera the daemon lists with realdds (``pyrealsense2.pyrealdds``), at once.

    import rsdiscovery.realdds

    dev = rsdiscovery.realdds.open("123622270732")      # a device, or its id, serial or topic-root
    print(dev.n_streams(), [s.name() for s in dev.streams()])
    frame = rsdiscovery.realdds.first_frame(dev)        # optional: the first image of a stream
    print(frame.width, frame.height, frame.timestamp)

:func:`open` builds the ``pyrealdds.device`` from the device-info the daemon kept (no wait
on the device-info topic) and returns it ready: its streams, options and profiles received.
It makes the DDS participant on the camera's domain once per process and domain and keeps it
(:func:`participant`), so a second camera on that domain opens without one.

Needs ``pyrealsense2`` (2.56 or later, with DDS): ``pip install 'rsdiscovery[realdds]'``.
Errors: :class:`Pyrealsense2Missing`, :class:`NotANetworkCamera`, :class:`DeviceGone`,
:class:`NotReady` (a :class:`TimeoutError`), and the package's :class:`NotFound`.
"""
from __future__ import annotations

import os
import sys
import threading
import time
from typing import Any, Dict, NamedTuple, Optional, Set, Tuple

from ._model import Device
from ._query import _check_seconds
from ._open import (
    DeviceGone,
    NotANetworkCamera,
    NotReady,
    OpenError,
    Pyrealsense2Missing,
    StillListed,
    device_info,
    gone_error,
    is_network,
    resolve,
)

__all__ = ["open", "participant", "first_frame", "Frame", "last_open", "OpenError", "Pyrealsense2Missing",
           "NotANetworkCamera", "DeviceGone", "NotReady"]

_POLL = 0.001          # how often readiness and matching are looked at (no callbacks: see _Probe)
_PATIENCE = 0.02       # a participant whose camera topics have not matched by then gets a second one ...
_PRODS = 5             # ... at most this many, waiting twice as long each time (see open())
_CONTROL_GRACE = 0.2   # how long a matched notification topic waits for the control topic to match

_lock = threading.Lock()
_participants: Dict[int, Any] = {}
# (participant guid, topic-root) already matched by open(): the participant keeps what it
# learned of the server's endpoints, so a second open needs no probe (whose topics would
# clash with the first device's: realdds logs that as an error).
_matched: Set[Tuple[str, str]] = set()

#: How the last :func:`open` went, for diagnostics: ``{"camera": id, "marks": {step: seconds
#: since the call}, "prods": n, "replaced": True}``. Steps: resolved (the daemon asked, when
#: given an id), imported (pyrealsense2, the first time), participant, heard (the server's
#: participant), matched (its notification and control topics), device (made), ready.
#: "prods": participants made because the first did not match in time; "replaced": one of
#: them is kept for the domain now.
last_open: Dict[str, Any] = {}


def _pyrealdds() -> Any:
    try:
        from pyrealsense2 import pyrealdds  # type: ignore[import-not-found, import-untyped, unused-ignore]
    except ImportError as e:
        have = "pyrealsense2 is installed but has no pyrealdds (it needs 2.56 or later, built with DDS)" \
            if "pyrealsense2" in sys.modules or _importable("pyrealsense2") else "pyrealsense2 is not installed"
        raise Pyrealsense2Missing(f"rsdiscovery.realdds needs pyrealsense2 with DDS: {have}; install the "
                                  "optional extra: pip install 'rsdiscovery[realdds]' (from the repository: "
                                  "pip install './client/python[realdds]'), or pip install pyrealsense2",
                                  name="pyrealsense2.pyrealdds") from e
    return pyrealdds


def _importable(name: str) -> bool:
    import importlib.util

    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def _participant_name() -> str:
    script = os.path.basename(sys.argv[0]) if sys.argv and sys.argv[0] else ""
    return f"rsdiscovery {script}".strip() if script not in ("", "-c", "-") else "rsdiscovery"


def participant(domain: int) -> Any:
    """This process's ``pyrealdds.participant`` on DDS domain `domain`, made on first use and
    kept: :func:`open` uses it, and so may the caller (for more cameras, or its own topics)."""
    if isinstance(domain, bool) or not isinstance(domain, int) or not 0 <= domain <= 232:
        raise ValueError(f"domain must be a DDS domain id, a whole number from 0 to 232, not {domain!r}")
    return _kept(domain)[0]


def _kept(domain: int) -> "tuple[Any, bool]":
    """(the kept participant, whether this call made it)."""
    dds = _pyrealdds()
    with _lock:
        p = _participants.get(domain)
        if p is not None:
            return p, False
        p = dds.participant()
        p.init(domain, _participant_name())
        _participants[domain] = p
        return p, True


def _new_participant(dds: Any, domain: int) -> Any:
    p = dds.participant()
    p.init(domain, _participant_name())
    return p


def _replace(domain: int, old: Any, new: Any) -> None:
    """`new` serves the domain from now on, in place of `old` (made by this process's open())."""
    with _lock:
        if _participants.get(domain) is old:
            _participants[domain] = new


class _Probe:
    """A reader of the camera's notification topic and a writer of its control topic, made
    before the device: matched, they say that this participant knows the server's two
    endpoints. A device made after that has its notification reader and control writer
    matched locally at once, so the initialization set the server sends when it matches the
    new reader is received, not dropped as coming from a writer not yet known (then it would
    come again only after Fast DDS' initial acknack delay, 70 ms), and a control sent at once
    is not lost either. Polled, never called back: a Python callback on a DDS thread that
    waits for the GIL while the main thread, holding it, makes a device, deadlocks."""

    def __init__(self, dds: Any, p: Any, root: str, known: bool = False) -> None:
        self._dds = dds
        self._reader = self._writer = None
        self.notification_at: Optional[float] = None
        if known:
            return  # not usable: nothing to wait for
        try:
            self._reader = dds.topic_reader(dds.message.flexible.create_topic(p, root + "/notification"))
            self._reader.run(dds.topic_reader.qos(dds.reliability.reliable, dds.durability.volatile))
            self._writer = dds.topic_writer(dds.message.flexible.create_topic(p, root + "/control"))
            self._writer.run(dds.topic_writer.qos(dds.reliability.reliable, dds.durability.volatile))
        except (AttributeError, TypeError):  # a pyrealdds without these: go on without probing
            self.close()

    @property
    def usable(self) -> bool:
        return self._reader is not None and self._writer is not None

    def notification(self) -> bool:
        if self.notification_at is None and self._reader is not None \
                and self._reader.wait_for_writers(self._dds.time(0)):  # a zero timeout only looks
            self.notification_at = time.monotonic()
        return self.notification_at is not None

    def control(self) -> bool:
        return self._writer is not None and bool(self._writer.has_readers())

    def close(self) -> None:
        if self._reader is not None:
            self._reader.stop()  # releases the GIL while the reader goes
        self._reader = self._writer = None


def open(device: Any, *, participant: Any = None, timeout: float = 5.0, endpoint: Any = None) -> Any:  # noqa: A001
    """A ready ``pyrealsense2.pyrealdds.device`` for a network camera the daemon lists.

    `device` is a camera from :func:`rsdiscovery.list_devices`, :func:`rsdiscovery.get_device`
    or :func:`rsdiscovery.wait_for`, or its id, serial or topic-root (the daemon at
    `endpoint` is asked for it; :class:`rsdiscovery.NotFound` when it lists none). The device
    is made from the device-info the daemon kept, on `participant` (a ``pyrealdds.participant``
    on the camera's domain) or else on this process's own for that domain (:func:`participant`),
    and returned once ``is_ready()``: its streams, options and profiles received.

    Raises :class:`NotANetworkCamera` for a camera the daemon sees on USB only,
    :class:`DeviceGone` when the daemon stops listing it meanwhile, :class:`NotReady` (a
    ``TimeoutError``, with ``stage``) when it is not ready within `timeout` seconds, and
    :class:`Pyrealsense2Missing` without pyrealsense2.
    """
    t0 = time.monotonic()
    cam = resolve(device, endpoint, timeout)
    resolved = time.monotonic() - t0
    if not is_network(cam):
        seen = ", ".join(cam.sources)
        raise NotANetworkCamera(f"camera {cam.id} ({cam.name}) is not a network camera: rs-discoveryd sees "
                                f"it on {seen}; open it with rsdiscovery.librealsense.device()")
    dds = _pyrealdds()
    assert cam.domain is not None and cam.topic_root is not None  # is_network
    domain, root = cam.domain, cam.topic_root
    deadline = t0 + timeout
    still = StillListed(cam, endpoint)
    server = cam.server.participant_name if cam.server is not None else None

    marks: Dict[str, float] = {"resolved": resolved, "imported": time.monotonic() - t0}
    last_open.clear()
    last_open.update(camera=cam.id, marks=marks)
    if participant is not None:
        p, fresh = participant, False
    else:
        p, fresh = _kept(domain)
    marks["participant"] = time.monotonic() - t0
    stage = "discovery"
    key = (str(p.guid()), root)
    # 1. A participant learns the server's notification and control endpoints.
    #
    # A new participant's first announcement reaches the server at once, and the server
    # answers at once (its own announcement, then its endpoints): now and then (on loopback
    # 1 start in 4 or 5) so fast that the answer arrives before the new participant is ready
    # for it, and is dropped. It would hear the server at its next periodic announcement, up
    # to 1.5 s later (realdds' announcement period), and get its endpoints 70 ms after that
    # (Fast DDS' initial acknack delay); its endpoints alone can be lost the same way (70 ms
    # then). So, when the camera's topics are not matched within _PATIENCE, one more
    # participant is made: the server, hearing a new participant, announces itself again to
    # everyone it knows (the first participant hears it now), and the new one has its own
    # chance of a clean start. The first of them to match the camera's topics is kept; a
    # participant not made by this call (the caller's, or one already in use) is only
    # prodded so, and the prodding participant dropped.
    candidates = [(p, _Probe(dds, p, root, known=key in _matched))]
    winner = None
    try:
        extra, patience, since = 0, _PATIENCE, time.monotonic()
        while candidates[0][1].usable:
            if "heard" not in marks and any(_heard(c, server) for c, _ in candidates):
                marks["heard"] = time.monotonic() - t0
            for c, probe in candidates:
                if probe.notification():
                    stage = "matching"
                    if probe.control() or time.monotonic() - (probe.notification_at or 0.0) > _CONTROL_GRACE:
                        winner = (c, probe)
                        break
            if winner:
                break
            now = time.monotonic()
            if now >= deadline:
                heard = stage == "matching" or any(_heard(c, server) is True for c, _ in candidates)
                raise _not_ready(cam, "matching" if heard else "discovery", now - t0, timeout)
            if extra < _PRODS and now - since > patience and not any(pr.notification_at for _, pr in candidates):
                more = _new_participant(dds, domain)
                candidates.append((more, _Probe(dds, more, root) if fresh else _Probe(dds, more, root, known=True)))
                extra, patience, since = extra + 1, patience * 2, time.monotonic()
                last_open["prods"] = extra
            if still.gone():
                raise gone_error(cam, now - t0)
            time.sleep(_POLL)
        marks["matched"] = time.monotonic() - t0
    finally:
        # The probes go before the device is made, which makes the same topics (the
        # participant keeps what it learned of the server's endpoints).
        for _, probe in candidates:
            probe.close()
    if winner is not None:
        if winner[0] is not p:
            _replace(domain, p, winner[0])
            p = winner[0]
            last_open["replaced"] = True
        _matched.add((str(p.guid()), root))
    losers = [c for c, _ in candidates[1:] if c is not p] + ([candidates[0][0]] if candidates[0][0] is not p else [])
    candidates.clear()  # drop the probes (and their readers) now
    winner = None
    # 2. The device: its reader is matched to the server's writer as it is made.
    stage = "initialization"
    dev = dds.device(p, dds.message.device_info.from_json(device_info(cam)))
    marks["device"] = time.monotonic() - t0
    while not dev.is_ready():
        now = time.monotonic()
        if now >= deadline:
            raise _not_ready(cam, stage, now - t0, timeout)
        if still.gone():
            raise gone_error(cam, now - t0)
        time.sleep(_POLL)
    marks["ready"] = time.monotonic() - t0
    del losers[:]  # the participants that lost go now (the caller's own stays theirs)
    return dev


def _heard(p: Any, server_name: Optional[str]) -> Optional[bool]:
    """Whether participant `p` has heard the camera's server (None: its name is not known)."""
    if not server_name:
        return None
    try:
        return server_name in p.names()
    except Exception:  # noqa: BLE001  (an older pyrealdds)
        return None


def _not_ready(cam: Device, stage: str, elapsed: float, timeout: float) -> NotReady:
    what = {
        "discovery": "this process never heard its DDS server (a firewall, or another network: "
                     "'rs-discover doctor' says which)",
        "matching": "its server's notification and control topics never matched",
        "initialization": "its server did not send its whole initialization set (device header and options, "
                          "every stream's header and options)",
    }[stage]
    return NotReady(f"camera {cam.id} ({cam.name}) not ready within {timeout:g} s: {what}", stage, elapsed)


class Frame(NamedTuple):
    """The first image of a stream, as its server published it."""

    stream: str
    width: int
    height: int
    encoding: str      # realdds' name, for example 'rgb8', '16UC1' (z16), 'mono8' (y8)
    timestamp: float   # seconds since the epoch, the server's clock
    data: bytes


def _stream_topic(root: str, stream: str) -> str:
    """realdds' ROS-friendly name of a stream's topic: 'rt/' + root + '_' + stream name (every
    '/' after the first one written '_')."""
    name = root + "/" + stream
    first = name.find("/")
    return "rt/" + name[:first + 1] + name[first + 1:].replace("/", "_")


def first_frame(dev: Any, stream: Optional[str] = None, *, timeout: float = 5.0) -> Frame:
    """The first image of a video stream of the ready device `dev` (from :func:`open`): the
    stream named `stream`, else the first video stream. Subscribing is what starts a realdds
    stream; the server streams its current profile (its default unless some client chose
    another with ``open-streams``). Raises :class:`NotReady` (stage ``"streaming"``) when no
    image arrives within `timeout` seconds, ValueError for an unknown stream."""
    _check_seconds("timeout", timeout, allow_zero=False)
    dds = _pyrealdds()
    t0 = time.monotonic()
    video = [s for s in dev.streams() if s.type_string() != "motion"]
    if stream is None:
        if not video:
            raise ValueError("the camera has no video stream")
        chosen = video[0]
    else:
        named = [s for s in dev.streams() if s.name() == stream]
        if not named or named[0].type_string() == "motion":
            raise ValueError(f"no video stream {stream!r}; the camera's: {[s.name() for s in video]}")
        chosen = named[0]
    root = dev.device_info().topic_root
    # A reader of the images polled (no callback: see _Probe), which also hands the data over
    # without making a list of every byte, as stream.on_data_available does.
    reader = dds.topic_reader(dds.message.image.create_topic(dev.participant(), _stream_topic(root, chosen.name())))
    reader.run(dds.topic_reader.qos(dds.reliability.best_effort, dds.durability.volatile))
    try:
        while True:
            image = dds.message.image.take_next(reader)
            if image:
                return Frame(chosen.name(), image.width, image.height, image.encoding, image.timestamp.to_double(),
                             bytes(image.data))
            if time.monotonic() - t0 >= timeout:
                raise NotReady(f"no image on stream {chosen.name()!r} of {root} within {timeout:g} s", "streaming",
                               time.monotonic() - t0)
            time.sleep(_POLL)
    finally:
        reader.stop()
