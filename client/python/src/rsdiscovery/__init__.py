"""Client of rs-discoveryd, the daemon that keeps a live table of Intel RealSense cameras.

The daemon's documents are frozen, typed objects (:class:`Device`, :class:`Participant`,
:class:`DomainStatus`, :class:`Health`): the JSON fields as snake_case attributes
(``dev.serial``, ``dev.topic_root``, ``dev.server.addresses``), and the JSON as the daemon
sent it in ``raw``. A ``domain`` argument takes one DDS domain id or several. A
:class:`Client` is a context manager: leaving it ends its watches. Standard library only.

Opening a camera the daemon lists, at once (these need ``pyrealsense2``, the optional extra
``rsdiscovery[realdds]``, and import it only when called): ``rsdiscovery.realdds.open`` (a
ready ``pyrealdds.device``) and ``rsdiscovery.librealsense.device`` (a librealsense context
and ``rs.device``). Their errors are here too, subclasses of :class:`OpenError`.
"""
from ._client import (
    Client,
    DaemonNotRunning,
    Endpoint,
    Event,
    Gone,
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
from ._expected import Expected, ExpectedCamera, WaitTimeout
from ._history import DeviceHistory, GoneDevice, History, HistoryChange
from ._model import (CameraClient, Device, DeviceClients, DomainStatus, Health, Host, InUse, Interface, Participant,
                     Server, Usb, UsbStatus)
from ._open import DeviceGone, NotANetworkCamera, NotReady, OpenError, Pyrealsense2Missing
from ._query import Domains

__version__ = "0.2.0"

__all__ = [
    "CameraClient",
    "Client",
    "DaemonNotRunning",
    "Device",
    "DeviceClients",
    "DeviceGone",
    "DeviceHistory",
    "Gone",
    "GoneDevice",
    "History",
    "HistoryChange",
    "DomainStatus",
    "Domains",
    "Endpoint",
    "Event",
    "Expected",
    "ExpectedCamera",
    "HTTPError",
    "Health",
    "Host",
    "InUse",
    "Interface",
    "MalformedReply",
    "NotANetworkCamera",
    "NotFound",
    "NotReady",
    "OpenError",
    "Participant",
    "PermissionDenied",
    "Pyrealsense2Missing",
    "RSDiscoveryError",
    "Server",
    "Usb",
    "UsbStatus",
    "VersionMismatch",
    "WaitTimeout",
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
