"""Cameras' comings and goings as the daemon keeps them (proto/openapi.yaml: GoneDevice,
HistoryChange, DeviceHistory, History), as frozen, typed objects like those of _model."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Optional, Tuple

from ._model import Device, _Read

__all__ = ["GoneDevice", "HistoryChange", "DeviceHistory", "History", "REMOVAL_REASONS"]

# RemovalReason in the spec, in its order.
REMOVAL_REASONS = ("stopping", "writer-gone", "lease-expired", "unplugged", "interface-gone", "domain-left",
                   "refused")


@dataclass(frozen=True)
class GoneDevice:
    """A camera that was here and left: ``reason`` (one of REMOVAL_REASONS), when it was
    removed, when it was last heard from, and ``device`` as it was last listed."""

    id: str
    reason: str
    removed_at: str
    last_seen: str
    detail: Optional[str]
    device: Device
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "GoneDevice":
        r = _Read(doc, "a gone device")
        return GoneDevice(id=r.req("id", str), reason=r.req("reason", str), removed_at=r.req("removed-at", str),
                          last_seen=r.get("last-seen", str, ""), detail=r.opt("detail", str),
                          device=Device.from_json(r.req("device", dict)), raw=r.doc)


@dataclass(frozen=True)
class HistoryChange:
    """One change of a camera's presence: ``event`` ``added`` (``arrival`` ``new`` or
    ``back``) or ``removed`` (with its ``reason``); ``generation`` is its event's id."""

    id: str
    generation: int
    at: str
    event: str
    reason: Optional[str]
    arrival: Optional[str]
    flap: bool
    detail: Optional[str]
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "HistoryChange":
        r = _Read(doc, "a history change")
        return HistoryChange(id=r.req("id", str), generation=r.req("generation", int), at=r.req("at", str),
                             event=r.req("event", str), reason=r.opt("reason", str), arrival=r.opt("arrival", str),
                             flap=r.get("flap", bool, False), detail=r.opt("detail", str), raw=r.doc)


def _changes(r: _Read) -> Tuple[HistoryChange, ...]:
    changes = r.req("changes", list)
    return tuple(HistoryChange.from_json(c) for c in changes)


@dataclass(frozen=True)
class DeviceHistory:
    """One camera's history: ``state`` ``present`` or ``gone`` (then ``gone`` is set), its
    latest changes oldest first, ``removals``: times removed, by reason, and ``flaps``: times
    lost by lease and back within a minute."""

    id: str
    state: str
    changes: Tuple[HistoryChange, ...]
    removals: Mapping[str, int]
    flaps: int
    gone: Optional[GoneDevice]
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "DeviceHistory":
        r = _Read(doc, "a device's history")
        gone = r.opt("gone", dict)
        return DeviceHistory(id=r.req("id", str), state=r.req("state", str), changes=_changes(r),
                             removals=r.counts("removals"), flaps=r.get("flaps", int, 0), gone=GoneDevice.from_json(gone) if gone else None,
                             raw=r.doc)


@dataclass(frozen=True)
class History:
    """Every camera's changes after a generation; ``next`` is the ``since`` of the next page."""

    changes: Tuple[HistoryChange, ...]
    generation: int
    next: int
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "History":
        r = _Read(doc, "the history")
        return History(changes=_changes(r), generation=r.req("generation", int), next=r.req("next", int), raw=r.doc)
