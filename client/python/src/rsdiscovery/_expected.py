"""Expected cameras: the daemon's ``GET /v1/expected`` as typed objects, and waiting until
named cameras are listed (``Client.wait``), following the event stream."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Iterable, List, Mapping, Optional, Tuple

from ._errors import MalformedReply, RSDiscoveryError
from ._model import Device, _Read

if TYPE_CHECKING:
    from ._client import Client

__all__ = ["Expected", "ExpectedCamera", "WaitTimeout"]


@dataclass(frozen=True)
class ExpectedCamera:
    """One camera the daemon's configuration expects (``expect``): its ``serial`` or its
    ``topic_root`` as configured, the user's ``name`` ("" when unnamed); ``id`` of the
    device that is it when present; ``last_seen`` and ``reason`` when missing, where the
    daemon knows them."""

    name: str
    serial: Optional[str]
    topic_root: Optional[str]
    id: Optional[str]
    last_seen: Optional[str]
    reason: Optional[str]

    @property
    def key(self) -> str:
        """The serial, or the topic-root: what names the camera."""
        return self.serial or self.topic_root or ""

    def __str__(self) -> str:
        return f"{self.name} ({self.key})" if self.name else self.key

    @staticmethod
    def from_json(doc: Any) -> "ExpectedCamera":
        r = _Read(doc, "an expected camera")
        cam = ExpectedCamera(name=r.get("name", str, ""), serial=r.opt("serial", str),
                             topic_root=r.opt("topic-root", str), id=r.opt("id", str),
                             last_seen=r.opt("last-seen", str), reason=r.opt("reason", str))
        if not cam.key:
            raise MalformedReply("malformed reply from rs-discoveryd: an expected camera without serial or topic-root")
        return cam


@dataclass(frozen=True)
class Expected:
    """``GET /v1/expected``: the ``present`` and ``missing`` expected cameras, in the
    configuration's order; ``complete`` once the daemon's first discovery is over."""

    complete: bool
    present: Tuple[ExpectedCamera, ...]
    missing: Tuple[ExpectedCamera, ...]
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "Expected":
        r = _Read(doc, "the expected list")

        def cameras(key: str) -> Tuple[ExpectedCamera, ...]:
            value = r.req(key, list)
            return tuple(ExpectedCamera.from_json(c) for c in value)

        return Expected(complete=r.req("complete", bool), present=cameras("present"), missing=cameras("missing"),
                        raw=r.doc)


class WaitTimeout(RSDiscoveryError, TimeoutError):
    """``Client.wait`` ran out of time: ``missing`` names the cameras not listed (their
    keys), ``why`` says for each what the daemon knows (last seen, reason)."""

    def __init__(self, message: str, missing: List[str], why: List[str]) -> None:
        super().__init__(message)
        self.missing = missing
        self.why = why


def _names(d: Device, key: str) -> bool:
    return key in (d.id, d.serial, d.topic_root)


def _explain(key: str, shown: str, expected: Optional[Expected]) -> str:
    for m in expected.missing if expected else ():
        if m.key == key:
            known = [f"last listed at {m.last_seen}"] if m.last_seen else []
            known += [m.reason] if m.reason else []
            return f"{shown}: {', '.join(known)}" if known else f"{shown}: never listed since the daemon started"
    return shown


def wait(client: "Client", keys: Iterable[str], expected: bool, timeout: float) -> List[Device]:
    """Client.wait's body: the devices that are the cameras waited for, in their order."""
    wanted: List[Tuple[str, str]] = [(k, k) for k in keys]
    if expected:
        exp = client.expected()
        wanted += [(c.key, str(c)) for c in exp.present + exp.missing]
    deadline = time.monotonic() + timeout

    def found(devices: List[Device]) -> Optional[List[Device]]:
        out = []
        for key, _ in wanted:
            hit = next((d for d in devices if _names(d, key)), None)
            if hit is None:
                return None
            out.append(hit)
        return out

    with client.watcher() as w:  # the stream: each change arrives as an event, no polling
        while True:
            devices = w.devices()
            done = found(devices)
            if done is not None:
                return done
            left = deadline - time.monotonic()
            if left <= 0:
                break
            w.next(timeout=left)
    try:
        exp_now: Optional[Expected] = client.expected()
    except RSDiscoveryError:
        exp_now = None  # an older daemon: the names alone
    missing = [(k, s) for k, s in wanted if not any(_names(d, k) for d in devices)]
    why = [_explain(k, s, exp_now) for k, s in missing]
    raise WaitTimeout(f"timed out after {timeout} s; {len(missing)} of {len(wanted)} camera(s) missing: "
                      + "; ".join(why), [k for k, _ in missing], why)
