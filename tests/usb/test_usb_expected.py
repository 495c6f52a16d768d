"""An expected camera on USB, on an emulated bus (umockdev): missing at start, then
plugged, then unplugged, as /v1/expected, /healthz and the metric see it."""
import pytest

from conftest import wait_for
from test_usb import D455_SERIAL, bed, usb_daemon  # noqa: F401  (fixtures)
from usbbed import in_umockdev

pytestmark = pytest.mark.skipif(not in_umockdev(), reason="run under umockdev-wrapper (ctest does)")

METRIC = f'rsd_expected_camera_present{{name="arm",serial="{D455_SERIAL}"}}'


def present_metric(d):
    _, _, body = d.request("/metrics")
    return next(float(ln.rsplit(" ", 1)[1]) for ln in body.decode().splitlines() if ln.startswith(METRIC))


def test_expected_usb_camera_missing_plugged_unplugged(bed, usb_daemon):
    bed.plug("root-hubs")
    d, _ = usb_daemon(extra=["--expect", f"arm={D455_SERIAL}"])
    exp = d.get_json("/v1/expected")
    assert exp["missing"] == [{"name": "arm", "serial": D455_SERIAL}] and exp["present"] == [], exp
    assert present_metric(d) == 0
    path = bed.plug("d455-usb3")
    wait_for(lambda: d.get_json("/v1/expected")["present"], what="the camera plugged")
    assert d.get_json("/healthz")["expected"]["present"][0]["id"] == "usb-" + D455_SERIAL
    assert present_metric(d) == 1
    bed.unplug(path)
    wait_for(lambda: d.get_json("/v1/expected")["missing"], what="the camera unplugged")
    gone = d.get_json("/v1/expected")["missing"][0]
    assert gone["reason"] == "unplugged" and gone["last-seen"], gone
    assert present_metric(d) == 0
