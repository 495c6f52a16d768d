"""USB cameras through the one contract (issue 9): every kind of device document the
daemon writes (USB, USB with a warning, DDS and USB merged, a sighting merged away)
validates against proto/openapi.yaml, and what the daemon writes is what every client
shows: a USB 3 camera on a USB 2 link is `warning` in rs-discover and the Python package.
Runs under umockdev, as test_usb.py does (its fixtures are reused)."""
import json
import os
import sys

import pytest

from conftest import device_info, wait_for
from test_usb import D435_ID, D455_ID, D455_SERIAL, TimedEvents, bed, usb_daemon  # noqa: F401 (fixtures)
from usbbed import in_umockdev

TESTS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(TESTS, "api"))
sys.path.insert(0, os.path.join(TESTS, "client"))
sys.path.insert(0, os.path.join(os.path.dirname(TESTS), "client", "python", "src"))
from api_util import validate_response  # noqa: E402
from client_util import rs_discover  # noqa: E402
from test_cli import table  # noqa: E402

import rsdiscovery  # noqa: E402

pytestmark = pytest.mark.skipif(not in_umockdev(), reason="run under umockdev-wrapper (ctest does)")

D435_SERIAL = D435_ID[len("usb-"):]


def cli(bed, *args, endpoint):  # noqa: F811
    """rs-discover under this test's umockdev preload (bed.env() lets a sanitized build run)."""
    return rs_discover(*args, endpoint=endpoint, env=bed.env())


def test_usb2_link_warning_shows_in_every_client(bed, usb_daemon):  # noqa: F811
    bed.plug("root-hubs")
    bed.plug("d435-usb2")
    d, _ = usb_daemon()
    dev = wait_for(lambda: d.get_json("/v1/devices/" + D435_ID), 5, what="the D435 listed")
    [warning] = dev["warnings"]
    ep = "unix:" + d.socket

    r = cli(bed, "list", endpoint=ep)
    assert r.returncode == 0, r.stderr
    [row] = table(r.stdout)[1]
    assert row["SERIAL"] == D435_SERIAL and row["STATE"] == "warning", r.stdout
    r = cli(bed, "get", D435_SERIAL, endpoint=ep)  # by serial, as a user types it
    assert r.returncode == 0, r.stderr
    assert "State:        warning" in r.stdout
    assert "Warning:      " + warning in r.stdout

    got = rsdiscovery.Client(ep).get_device(D435_SERIAL)
    assert got.id == D435_ID and got.warnings == (warning,) and got.state == "warning"
    assert d.get_json("/v1/devices/" + D435_SERIAL)["id"] == D435_ID


def test_every_kind_of_device_validates_against_the_spec(bed, usb_daemon, realdds_server):  # noqa: F811
    bed.plug("root-hubs")
    bed.plug("d455-usb3")
    bed.plug("d435-usb2")
    d, domain = usb_daemon()
    listing = wait_for(lambda: (lambda x: x if len(x["devices"]) == 2 else None)(d.get_json("/v1/devices")), 5,
                       what="both USB cameras")
    validate_response("/v1/devices", 200, listing)
    for dev in listing["devices"]:
        validate_response("/v1/devices/{id}", 200, d.get_json("/v1/devices/" + dev["id"]))

    events = TimedEvents(d)
    info = device_info(0, serial=D455_SERIAL)
    server = realdds_server(domain, [info], name="spec-server")
    # The USB sighting joins the DDS one: it is removed, naming the entry it joined.
    removed = events.expect("removed", D455_ID, timeout=15)["json"]
    ev = events.next(15)
    assert ev["event"] == "added", ev
    merged = ev["json"]
    assert removed["merged-into"] == merged["id"]
    assert merged["sources"] == ["dds", "usb"] and "usb" in merged and "server" in merged
    for doc in (removed, merged):
        validate_response("/v1/devices/{id}", 200, doc)
    listing = d.get_json("/v1/devices")
    assert sorted(x["id"] for x in listing["devices"]) == sorted([merged["id"], D435_ID])
    validate_response("/v1/devices", 200, listing)
    validate_response("/v1/devices/{id}", 200, d.get_json("/v1/devices/" + D455_ID))  # the USB id finds it
    validate_response("/healthz", 200, d.get_json("/healthz"))
    validate_response("/v1/domains", 200, d.get_json("/v1/domains"))
    # The merged camera is one device to every client, with both parts.
    got = rsdiscovery.Client("unix:" + d.socket).get_device(D455_SERIAL)
    assert got.id == merged["id"] and got.usb.port_path == "2-1" and got.sources == ("dds", "usb")
    assert json.loads(cli(bed, "get", "--json", D455_SERIAL, endpoint="unix:" + d.socket).stdout)["id"] == \
        merged["id"]
    server.quit()
