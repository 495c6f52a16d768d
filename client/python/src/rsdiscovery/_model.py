"""The API's documents (proto/openapi.yaml) as frozen, typed objects: Device (with its Server
and Usb parts), Participant, DomainStatus and Health. Attribute names are the JSON names in
snake_case (``serial-number`` -> ``serial_number``); every object keeps the daemon's JSON
as it came in ``raw``, so a field this package does not know is still there."""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any, Dict, ItemsView, KeysView, Mapping, Optional, Tuple, Type, TypeVar

from ._errors import MalformedReply

__all__ = ["Device", "Server", "Usb", "Host", "Participant", "DomainStatus", "Interface", "Health", "UsbStatus"]

_T = TypeVar("_T")


class _Read:
    """Reads the fields of one JSON object; a field of the wrong type is a MalformedReply
    (the daemon promised otherwise), an absent optional one None."""

    def __init__(self, doc: Any, what: str) -> None:
        if not isinstance(doc, Mapping):
            raise MalformedReply(f"malformed reply from rs-discoveryd: {what} is not a JSON object")
        self.doc: Mapping[str, Any] = doc
        self.what = what

    def _bad(self, key: str, want: str) -> MalformedReply:
        return MalformedReply(f"malformed reply from rs-discoveryd: {self.what}'s {key!r} is not {want} "
                              f"({self.doc.get(key)!r})")

    def opt(self, key: str, kind: Type[_T]) -> Optional[_T]:
        value = self.doc.get(key)
        if value is None:
            return None
        # bool is an int to Python, never to JSON; an integral float is fine for a number.
        if kind is int and (isinstance(value, bool) or not isinstance(value, int)):
            raise self._bad(key, "a whole number")
        if kind is float and isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)  # type: ignore[return-value]
        if not isinstance(value, kind):
            raise self._bad(key, f"a {kind.__name__}")
        return value

    def req(self, key: str, kind: Type[_T]) -> _T:
        value = self.opt(key, kind)
        if value is None:
            raise MalformedReply(f"malformed reply from rs-discoveryd: {self.what} without {key!r}")
        return value

    def get(self, key: str, kind: Type[_T], default: _T) -> _T:
        value = self.opt(key, kind)
        return default if value is None else value

    def strings(self, key: str) -> Tuple[str, ...]:
        value = self.doc.get(key)
        if value is None:
            return ()
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise self._bad(key, "a list of strings")
        return tuple(value)

    def counts(self, key: str) -> Mapping[str, int]:
        value = self.doc.get(key)
        if value is None:
            return {}
        if not isinstance(value, dict) or not all(isinstance(v, int) and not isinstance(v, bool)
                                                  for v in value.values()):
            raise self._bad(key, "counts by reason")
        return value


class _Document:
    """Dict-style reading of ``raw``, as the package's documents were plain dicts before
    0.2: ``dev["topic-root"]``, ``dev.get("serial")``, ``"domain" in dev``. Kept so that
    code written then goes on working; each use warns (DeprecationWarning): use the
    attributes, or ``raw`` for the JSON as the daemon sent it."""

    raw: Mapping[str, Any]

    def _deprecated(self, how: str) -> None:
        warnings.warn(f"{type(self).__name__}{how}: the daemon's documents are typed objects now; use their "
                      f"attributes (snake_case), or .raw for the JSON", DeprecationWarning, stacklevel=3)

    def __getitem__(self, key: str) -> Any:
        self._deprecated(f"[{key!r}]")
        return self.raw[key]

    def get(self, key: str, default: Any = None) -> Any:
        self._deprecated(f".get({key!r})")
        return self.raw.get(key, default)

    def __contains__(self, key: object) -> bool:
        self._deprecated(f": {key!r} in")
        return key in self.raw

    def keys(self) -> KeysView[str]:
        self._deprecated(".keys()")
        return self.raw.keys()

    def items(self) -> ItemsView[str, Any]:
        self._deprecated(".items()")
        return self.raw.items()


@dataclass(frozen=True)
class Server(_Document):
    """The realdds server (DDS participant) that announced a network camera. Every field may
    be None: the daemon leaves them out when the announcing writer is unknown."""

    participant_guid: Optional[str]
    participant_name: Optional[str]
    writer_guid: Optional[str]
    addresses: Tuple[str, ...]
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "Server":
        r = _Read(doc, "a device's server")
        return Server(participant_guid=r.opt("participant-guid", str), participant_name=r.opt("participant-name", str),
                      writer_guid=r.opt("writer-guid", str), addresses=r.strings("addresses"), raw=r.doc)

    def __hash__(self) -> int:
        return hash((self.participant_guid, self.writer_guid))


@dataclass(frozen=True)
class Usb(_Document):
    """Where a USB camera is plugged, from its descriptor and sysfs. ``address`` changes on
    every replug; ``port_path`` is the kernel's name of the place (``2-1.4``); ``speed`` is
    ``low``, ``full``, ``high``, ``super``, ``super-plus`` or ``unknown``."""

    bus: int
    address: int
    port_path: str
    speed: str
    speed_mbps: Optional[float]
    vid: str
    pid: str
    usb_version: Optional[str]
    sysfs_path: Optional[str]
    raw: Mapping[str, Any] = field(repr=False)
    device_nodes: Tuple[str, ...] = ()  # this host's device files of the camera (/dev/bus/usb/..., /dev/video0 ...)

    @staticmethod
    def from_json(doc: Any) -> "Usb":
        r = _Read(doc, "a device's usb")
        return Usb(bus=r.get("bus", int, 0), address=r.get("address", int, 0), port_path=r.get("port-path", str, ""),
                   speed=r.get("speed", str, "unknown"), speed_mbps=r.opt("speed-mbps", float),
                   vid=r.get("vid", str, ""), pid=r.get("pid", str, ""), usb_version=r.opt("usb-version", str),
                   sysfs_path=r.opt("sysfs-path", str), raw=r.doc, device_nodes=r.strings("device-nodes"))

    def __hash__(self) -> int:
        return hash((self.bus, self.address, self.port_path))


@dataclass(frozen=True)
class Host(_Document):
    """The host whose daemon shares a ``remote-usb`` camera (it runs with share-usb): its
    ``name`` and the ``addresses`` its daemon joined the DDS domain on, as it announces them;
    ``participant_guid`` is that daemon's DDS participant, where the daemon says it."""

    name: str
    addresses: Tuple[str, ...]
    participant_guid: Optional[str]
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "Host":
        r = _Read(doc, "a device's host")
        return Host(name=r.req("name", str), addresses=r.strings("addresses"),
                    participant_guid=r.opt("participant-guid", str), raw=r.doc)

    def __hash__(self) -> int:
        return hash((self.name, self.addresses))


@dataclass(frozen=True)
class InUse:
    """A network camera's clients in short (the device's ``in-use``): how many DDS
    participants use it, and the streams read now (:meth:`Client.clients` says who)."""

    clients: int
    streaming: Tuple[str, ...]

    @staticmethod
    def from_json(doc: Any) -> "InUse":
        r = _Read(doc, "a device's in-use")
        return InUse(clients=r.req("clients", int), streaming=r.strings("streaming"))


@dataclass(frozen=True)
class Device(_Document):
    """A camera as rs-discoveryd knows it (``GET /v1/devices``, ``/v1/devices/{id}``, events).

    Attributes are the JSON fields in snake_case (``topic-root`` -> ``topic_root``); those
    the daemon does not send for this camera are None (``domain``, ``topic_root`` and
    ``server`` for a USB camera; ``usb`` for a network one; ``host`` for every camera but
    another host's USB one, ``source`` ``remote-usb``; ``in_use`` for a camera with no
    client), or empty (``warnings``).
    ``sources`` holds every source that sees the camera (``("dds", "usb")`` for one seen both
    ways); ``first_seen`` and ``last_seen`` are RFC 3339 UTC strings, as sent. ``raw`` is the
    document exactly as the daemon sent it: the camera's whole realdds device-info is in it,
    also the fields this class does not name. Frozen: compare, hash and keep them freely.
    """

    id: str
    name: str
    source: str
    sources: Tuple[str, ...]
    serial: Optional[str]
    product_line: Optional[str]
    product_id: Optional[str]
    fw_version: Optional[str]
    recovery: bool
    domain: Optional[int]
    topic_root: Optional[str]
    server: Optional[Server]
    usb: Optional[Usb]
    warnings: Tuple[str, ...]
    first_seen: str
    last_seen: str
    merged_into: Optional[str]
    raw: Mapping[str, Any] = field(repr=False)
    # Last and defaulted: a Device made by keyword or position as before it stays valid.
    host: Optional[Host] = None
    in_use: Optional[InUse] = None

    @staticmethod
    def from_json(doc: Any) -> "Device":
        """The device of a JSON document as the daemon serves it (a dict); raises
        :class:`MalformedReply` for one without an ``id`` or with a field of the wrong type.
        The fields the API requires besides ``id`` may be absent (a made-up document, an
        older daemon): they are then empty."""
        r = _Read(doc, "a device")
        source = r.get("source", str, "")
        server = doc.get("server")
        usb = doc.get("usb")
        host = doc.get("host")
        in_use = doc.get("in-use")
        return Device(id=r.req("id", str), name=r.get("name", str, ""), source=source,
                      sources=r.strings("sources") or ((source,) if source else ()), serial=r.opt("serial", str),
                      product_line=r.opt("product-line", str), product_id=r.opt("product-id", str),
                      fw_version=r.opt("fw-version", str), recovery=r.get("recovery", bool, False),
                      domain=r.opt("domain", int), topic_root=r.opt("topic-root", str),
                      server=Server.from_json(server) if server is not None else None,
                      usb=Usb.from_json(usb) if usb is not None else None, warnings=r.strings("warnings"),
                      first_seen=r.get("first-seen", str, ""), last_seen=r.get("last-seen", str, ""),
                      merged_into=r.opt("merged-into", str), raw=r.doc,
                      host=Host.from_json(host) if host is not None else None,
                      in_use=InUse.from_json(in_use) if in_use is not None else None)

    def __hash__(self) -> int:
        return hash((self.id, self.last_seen))

    @property
    def is_network(self) -> bool:
        """Seen over DDS, with the domain and topic-root a realdds client opens it by."""
        return "dds" in self.sources and self.domain is not None and self.topic_root is not None

    @property
    def is_usb(self) -> bool:
        """Seen on this machine's USB."""
        return "usb" in self.sources

    @property
    def state(self) -> str:
        """``recovery``, ``warning`` (see ``warnings``) or ``ok``, as rs-discover shows it."""
        return "recovery" if self.recovery else "warning" if self.warnings else "ok"


@dataclass(frozen=True)
class Participant(_Document):
    """A DDS participant the daemon hears (``GET /v1/participants``): a realdds server, a
    librealsense or ROS program, another DDS tool. ``state`` is ``alive`` or ``gone``;
    ``vendor`` ``fast-dds``, ``cyclone-dds``, ``rti-connext``, ``opendds`` or ``other``;
    ``host``, ``process`` and ``pid`` only where the peer says them (Cyclone DDS ones do)."""

    domain: int
    guid: str
    name: str
    vendor: str
    vendor_id: str
    addresses: Tuple[str, ...]
    host: Optional[str]
    process: Optional[str]
    pid: Optional[int]
    lease_seconds: Optional[float]
    state: str
    first_seen: str
    last_seen: str
    device_info_writers: int
    devices: int
    silent_writers: int
    never_announced: bool
    topic_roots: Tuple[str, ...]
    endpoints: int
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "Participant":
        r = _Read(doc, "a participant")
        return Participant(domain=r.req("domain", int), guid=r.req("guid", str), name=r.get("name", str, ""),
                           vendor=r.get("vendor", str, "other"), vendor_id=r.get("vendor-id", str, ""),
                           addresses=r.strings("addresses"), host=r.opt("host", str), process=r.opt("process", str),
                           pid=r.opt("pid", int), lease_seconds=r.opt("lease-seconds", float),
                           state=r.req("state", str), first_seen=r.get("first-seen", str, ""),
                           last_seen=r.get("last-seen", str, ""),
                           device_info_writers=r.get("device-info-writers", int, 0), devices=r.get("devices", int, 0),
                           silent_writers=r.get("silent-writers", int, 0),
                           never_announced=r.get("never-announced", bool, False),
                           topic_roots=r.strings("topic-roots"), endpoints=r.get("endpoints", int, 0), raw=r.doc)

    def __hash__(self) -> int:
        return hash((self.domain, self.guid, self.state))


@dataclass(frozen=True)
class CameraClient(_Document):
    """A program using a network camera (``GET /v1/devices/{id}/clients``): a DDS
    participant other than the camera's server with a reader or writer on its topics.
    ``since`` is when its first one was discovered; ``streams`` the streams it reads;
    ``ros_nodes``, when it is a ROS 2 node, the nodes owning those readers and writers
    (ROS 2 participants are all named "/")."""

    guid: str
    name: str
    vendor: str
    vendor_id: str
    addresses: Tuple[str, ...]
    host: Optional[str]
    process: Optional[str]
    pid: Optional[int]
    since: str
    streams: Tuple[str, ...]
    ros_nodes: Tuple[str, ...]
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "CameraClient":
        r = _Read(doc, "a camera's client")
        return CameraClient(guid=r.req("guid", str), name=r.get("name", str, ""), vendor=r.get("vendor", str, "other"),
                            vendor_id=r.get("vendor-id", str, ""), addresses=r.strings("addresses"),
                            host=r.opt("host", str), process=r.opt("process", str), pid=r.opt("pid", int),
                            since=r.get("since", str, ""), streams=r.strings("streams"),
                            ros_nodes=r.strings("ros-nodes"), raw=r.doc)


@dataclass(frozen=True)
class DeviceClients:
    """Who uses a network camera: its ``clients``, and ``streams``, each stream some
    client reads now with its number of readers."""

    clients: Tuple[CameraClient, ...]
    streams: Mapping[str, int]

    @staticmethod
    def from_json(doc: Any) -> "DeviceClients":
        if not isinstance(doc, dict) or not isinstance(doc.get("clients"), list) or not isinstance(
                doc.get("streams"), dict):
            raise MalformedReply("malformed reply from rs-discoveryd: not a device's clients")
        streams: Dict[str, int] = {}
        for name, readers in doc["streams"].items():
            if not isinstance(readers, int) or isinstance(readers, bool):
                raise MalformedReply(f"malformed reply from rs-discoveryd: readers of {name!r} is not a count")
            streams[name] = readers
        return DeviceClients(clients=tuple(CameraClient.from_json(c) for c in doc["clients"]), streams=streams)


@dataclass(frozen=True)
class Interface:
    """A network interface a domain is joined on, with its IPv4 addresses."""

    name: str
    addresses: Tuple[str, ...]


@dataclass(frozen=True)
class DomainStatus(_Document):
    """One DDS domain the daemon joined (``GET /v1/domains``). ``state`` is ``settling``,
    ``running``, ``rebuilding``, ``failed`` (``error`` says why) or ``stopped``;
    ``complete`` is true once its first discovery is over; ``participant_guid`` is the
    daemon's own participant there. The counters are as proto/openapi.yaml describes them:
    device-info messages ``accepted``, ``rejected`` by reason, ``rebuilds``, ``refreshes``,
    ``lost_servers``, ``writers_refused`` and ``endpoints_refused`` by reason,
    ``network_changes``."""

    domain: int
    state: str
    participant_guid: str
    error: str
    devices: int
    accepted: int
    stopping: int
    rejected: Mapping[str, int]
    rebuilds: int
    refreshes: int
    lost_servers: int
    device_info_writers: int
    writers_refused: Mapping[str, int]
    endpoints_refused: Mapping[str, int]
    interfaces: Tuple[Interface, ...]
    network_changes: int
    network_changed_at: str
    complete: bool
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "DomainStatus":
        r = _Read(doc, "a domain")
        interfaces = r.get("interfaces", list, [])
        return DomainStatus(domain=r.req("domain", int), state=r.req("state", str),
                            participant_guid=r.get("participant-guid", str, ""), error=r.get("error", str, ""),
                            devices=r.get("devices", int, 0), accepted=r.get("accepted", int, 0),
                            stopping=r.get("stopping", int, 0), rejected=r.counts("rejected"),
                            rebuilds=r.get("rebuilds", int, 0), refreshes=r.get("refreshes", int, 0),
                            lost_servers=r.get("lost-servers", int, 0),
                            device_info_writers=r.get("device-info-writers", int, 0),
                            writers_refused=r.counts("writers-refused"),
                            endpoints_refused=r.counts("endpoints-refused"),
                            interfaces=tuple(Interface(name=i.req("name", str), addresses=i.strings("addresses"))
                                             for i in (_Read(x, "a domain's interface") for x in interfaces)),
                            network_changes=r.get("network-changes", int, 0),
                            network_changed_at=r.get("network-changed-at", str, ""),
                            complete=r.get("complete", bool, True), raw=r.doc)

    def __hash__(self) -> int:
        return hash((self.domain, self.state, self.participant_guid))


@dataclass(frozen=True)
class UsbStatus(_Document):
    """The daemon's USB source: ``state`` ``off``, ``stopped``, ``unavailable`` (``error``
    says why), ``hotplug`` or ``polling``; ``devices`` while it watches."""

    state: str
    devices: Optional[int]
    error: Optional[str]
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "UsbStatus":
        r = _Read(doc, "the health's usb")
        return UsbStatus(state=r.req("state", str), devices=r.opt("devices", int), error=r.opt("error", str),
                         raw=r.doc)

    def __hash__(self) -> int:
        return hash((self.state, self.devices))


@dataclass(frozen=True)
class Health(_Document):
    """The daemon's ``GET /healthz``: ``status`` ``ok``, its ``version``, the number of
    ``devices``, the table's ``generation``, ``complete`` (false while its first discovery
    still runs: ``devices`` is not final then) and its USB source."""

    status: str
    version: str
    devices: int
    generation: int
    complete: bool
    usb: Optional[UsbStatus]
    raw: Mapping[str, Any] = field(repr=False)

    @staticmethod
    def from_json(doc: Any) -> "Health":
        r = _Read(doc, "the health")
        usb = doc.get("usb")
        return Health(status=r.req("status", str), version=r.get("version", str, ""), devices=r.get("devices", int, 0),
                      generation=r.get("generation", int, 0), complete=r.get("complete", bool, True),
                      usb=UsbStatus.from_json(usb) if usb is not None else None, raw=r.doc)

    def __hash__(self) -> int:
        return hash((self.status, self.generation))
