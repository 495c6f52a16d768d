"""The Python package's typed API (issue 23): devices and the other documents as frozen,
typed objects equal to the JSON the daemon serves; Client a context manager that ends its
watches; several domains wherever rs-discover takes several; participants() alive by
default, like `rs-discover participants`; mypy --strict clean on the package. Against the
real daemon and real realdds servers (Fast DDS), one domain range per suite."""
import dataclasses
import json
import os
import subprocess
import sys

import pytest
from client_util import DOMAIN_RANGE, SOURCE, rs_discover
from conftest import device_info, wait_for

sys.path.insert(0, os.path.join(SOURCE, "client", "python", "src"))
import rsdiscovery  # noqa: E402  (the package as shipped)

PACKAGE_SRC = os.path.join(SOURCE, "client", "python", "src")

# The package's own calls never go through its deprecated dict-style access.
pytestmark = pytest.mark.filterwarnings("error::DeprecationWarning")


def steady(doc):
    """A participant without the one key that moves with time: an alive one's last-seen is now."""
    return {k: v for k, v in doc.items() if k != "last-seen"}


def snake(key):
    return key.replace("-", "_")


def typed(value):
    """A JSON value as the typed objects hold it: lists as tuples."""
    return tuple(typed(v) for v in value) if isinstance(value, list) else value


def assert_mirrors(obj, doc):
    """Every JSON field the object's class names is its attribute, with the same value;
    nested documents recursively; and raw is the document itself."""
    assert obj.raw == doc
    names = {f.name for f in dataclasses.fields(obj)}
    checked = 0
    for key, value in doc.items():
        if snake(key) not in names:
            continue
        attr = getattr(obj, snake(key))
        if dataclasses.is_dataclass(attr):
            assert_mirrors(attr, value)
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            assert [a.name for a in attr] == [v["name"] for v in value]  # interfaces
        else:
            assert attr == typed(value), (key, attr, value)
        checked += 1
    assert checked >= 3, (obj, doc)


@pytest.fixture
def camera(daemon, realdds_server, domains):
    """(daemon, domain, server, info): a realdds server announcing one D455."""
    domain = domains.take(*DOMAIN_RANGE)
    info = device_info(31)
    server = realdds_server(domain, [info], name="typed-server")
    d = daemon([domain])
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    return d, domain, server, info


def test_devices_are_typed_objects_equal_to_the_api_json(camera):
    d, domain, _, info = camera
    ep = "unix:" + d.socket
    (dev,) = rsdiscovery.list_devices(endpoint=ep)
    assert isinstance(dev, rsdiscovery.Device)
    (api,) = d.devices()
    assert_mirrors(dev, api)
    # What a user reads, by name: the camera's own device-info and what the daemon adds.
    assert (dev.id, dev.name, dev.serial, dev.product_line, dev.product_id, dev.fw_version) == (
        f"dds-{domain}-realsense.D455_{info['serial']}", info["name"], info["serial"], "D400", "0B5C", "5.16.0.1")
    assert (dev.source, dev.sources, dev.domain, dev.topic_root) == ("dds", ("dds",), domain, info["topic-root"])
    assert dev.server.participant_name == "typed-server" and dev.server.addresses == tuple(api["server"]["addresses"])
    assert dev.usb is None and dev.warnings == () and dev.recovery is False and dev.state == "ok"
    assert dev.is_network and not dev.is_usb
    # The same object from every call that returns a device.
    assert rsdiscovery.get_device(info["serial"], endpoint=ep) == dev
    assert rsdiscovery.wait_for(lambda x: x.serial == info["serial"], timeout=10, endpoint=ep) == dev
    with rsdiscovery.Client(ep) as c, c.watcher(initial=True) as w:
        e = w.next(10)
        assert e.type == "added" and e.device == dev and w.devices() == [dev]
    # The other documents.
    (dom,) = rsdiscovery.domains(endpoint=ep)
    assert isinstance(dom, rsdiscovery.DomainStatus)
    assert_mirrors(dom, d.get_json("/v1/domains")["domains"][0])
    assert dom.domain == domain and dom.state == "running" and dom.devices == 1 and dom.complete
    health = rsdiscovery.health(endpoint=ep)
    assert isinstance(health, rsdiscovery.Health) and health.status == "ok" and health.complete
    assert health.devices == 1 and health.usb.state == "off"
    (p,) = rsdiscovery.participants(endpoint=ep)
    assert isinstance(p, rsdiscovery.Participant)
    assert_mirrors(p, p.raw)
    (api_p,) = d.get_json("/v1/participants")["participants"]
    assert steady(p.raw) == steady(api_p)
    assert (p.name, p.vendor, p.state, p.devices, p.topic_roots) == (
        "typed-server", "fast-dds", "alive", 1, (info["topic-root"],))


def test_devices_are_frozen_hashable_and_read_as_dicts_with_a_warning(camera):
    d, _, _, info = camera
    (dev,) = rsdiscovery.list_devices(endpoint="unix:" + d.socket)
    for name, value in (("serial", "other"), ("domain", 3), ("raw", {})):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(dev, name, value)
    with pytest.raises(dataclasses.FrozenInstanceError):
        dev.server.addresses = ()
    assert dev.serial == info["serial"]
    again = rsdiscovery.get_device(dev.id, endpoint="unix:" + d.socket)
    assert {dev, again} == {dev} and {dev.id: 1}[again.id] == 1
    # Code written for the dicts of 0.1 goes on working, told to move on.
    with pytest.warns(DeprecationWarning, match=r"Device\['topic-root'\].*attributes"):
        assert dev["topic-root"] == info["topic-root"]
    with pytest.warns(DeprecationWarning):
        assert dev.get("serial") == info["serial"] and dev.get("nothing", 5) == 5
    with pytest.warns(DeprecationWarning):
        assert "domain" in dev
    # The JSON as it came: to print, to store, to hand to other tools.
    assert json.loads(json.dumps(dev.raw)) == d.devices()[0]


def event_streams(d):
    status, _, body = d.request("/metrics")
    assert status == 200
    for line in body.decode().splitlines():
        if line.startswith("rsd_event_streams "):
            return int(float(line.split()[1]))
    raise AssertionError("no rsd_event_streams in /metrics")


def test_client_is_a_context_manager_that_ends_its_watches(camera):
    d, _, _, _ = camera
    assert event_streams(d) == 0
    with rsdiscovery.Client("unix:" + d.socket) as c:
        assert not c.closed
        w = c.watcher()
        gen = c.watch(initial=True)
        assert next(gen).type == "added"
        wait_for(lambda: event_streams(d) == 2, 10, what="two event streams open")
    # Leaving the block closed every watch: the daemon's streams end, the iterators stop.
    assert c.closed
    wait_for(lambda: event_streams(d) == 0, 10, what="the client's event streams closed")
    assert w.next(timeout=5) is None and next(gen, None) is None
    with pytest.raises(rsdiscovery.RSDiscoveryError, match="closed"):
        c.list_devices()
    with pytest.raises(rsdiscovery.RSDiscoveryError, match="closed"):
        c.watcher()
    c.close()  # again: nothing happens
    # An exception leaving the block closes it too.
    with pytest.raises(KeyError):
        with rsdiscovery.Client("unix:" + d.socket) as c2:
            c2.watcher()
            wait_for(lambda: event_streams(d) == 1, 10, what="the stream open")
            raise KeyError("the user's own error")
    wait_for(lambda: event_streams(d) == 0, 10, what="the stream closed by the exception")


@pytest.fixture
def three_domains(daemon, realdds_server, domains):
    """(daemon, [a, b, c]): a daemon on three domains, a realdds server with one camera on each."""
    doms = [domains.take(*DOMAIN_RANGE) for _ in range(3)]
    for n, dom in enumerate(doms):
        realdds_server(dom, [device_info(40 + n)], name=f"server-{n}")
    d = daemon(doms)
    wait_for(lambda: len(d.devices()) == 3, 30, what="a camera on each domain")
    wait_for(lambda: len(d.get_json("/v1/participants")["participants"]) == 3, 20, what="the three servers")
    return d, doms


def test_several_domains_where_rs_discover_takes_several(three_domains):
    d, (a, b, c) = three_domains
    ep = "unix:" + d.socket
    ids = lambda devices: sorted(x.id for x in devices)  # noqa: E731
    want = sorted(x["id"] for x in d.devices(f"?domain={a}&domain={b}"))
    assert len(want) == 2
    # The same cameras as `rs-discover list -d A -d B` and the API with the parameter repeated,
    # from any iterable of ids.
    cli = json.loads(rs_discover("list", "--json", "-d", str(a), "-d", str(b), endpoint=ep).stdout)  # repeated
    assert sorted(x["id"] for x in cli["devices"]) == want
    for domains in ([a, b], (b, a), {a, b}, iter([a, b, a])):
        assert ids(rsdiscovery.list_devices(domain=domains, endpoint=ep)) == want
    assert ids(rsdiscovery.list_devices(domain=c, endpoint=ep)) == sorted(x["id"] for x in d.devices(f"?domain={c}"))
    with rsdiscovery.Client(ep) as client:
        first = client.wait_for(count=2, domain=iter([a, b]), timeout=10)
        assert first.domain in (a, b)
        with client.watcher(initial=True, domain=[a, c]) as w:
            seen = [w.next(10), w.next(10)]
            assert sorted(e.device.domain for e in seen) == sorted([a, c])
            assert sorted(x.domain for x in w.devices()) == sorted([a, c])  # b's camera never in the view
        assert sorted(p.domain for p in client.participants(domain=[b, c])) == sorted([b, c])
    r = subprocess.run([sys.executable, "-m", "rsdiscovery", "--endpoint", ep, "--json", "list", "-d", str(a),
                        "--domain", str(b)], capture_output=True, text=True, timeout=60,
                       env=dict(os.environ, PYTHONPATH=PACKAGE_SRC))
    assert r.returncode == 0, r.stderr
    assert sorted(x["id"] for x in json.loads(r.stdout)) == want
    for bad in ([], [a, 300], [a, "1"], "12", [True]):
        with pytest.raises(ValueError):
            rsdiscovery.list_devices(domain=bad, endpoint=ep)


def test_participants_alive_by_default_like_rs_discover(camera, realdds_server):
    d, domain, _, _ = camera
    ep = "unix:" + d.socket
    leaving = realdds_server(domain, [device_info(32)], name="leaving-server")
    wait_for(lambda: len(d.devices()) == 2, 20, what="the second server's camera")
    leaving.kill()
    wait_for(lambda: [p["name"] for p in d.get_json("/v1/participants?state=gone")["participants"]]
             == ["leaving-server"], 20, what="the killed server gone")
    alive = rsdiscovery.participants(endpoint=ep)
    assert [p.name for p in alive] == ["typed-server"] and all(p.state == "alive" for p in alive)
    cli = json.loads(rs_discover("participants", "--json", endpoint=ep).stdout)["participants"]
    assert [p["guid"] for p in cli] == [p.guid for p in alive]
    every = rsdiscovery.participants(state=None, endpoint=ep)
    assert [(p.name, p.state) for p in every] == [("typed-server", "alive"), ("leaving-server", "gone")]
    cli_all = json.loads(rs_discover("participants", "--all", "--json", endpoint=ep).stdout)["participants"]
    assert [p["guid"] for p in cli_all] == [p.guid for p in every]
    assert [p.guid for p in rsdiscovery.participants(state="all", endpoint=ep)] == [p.guid for p in every]
    assert [p.name for p in rsdiscovery.Client(ep).participants(state="gone")] == ["leaving-server"]
    with pytest.raises(ValueError):
        rsdiscovery.participants(state="sleeping", endpoint=ep)


def mypy(tmp_path, *args):
    # Its cache under tmp_path: nothing written into the tree, and the standard library's
    # stubs read once for the three runs.
    return subprocess.run([sys.executable, "-m", "mypy", "--strict", f"--cache-dir={tmp_path / 'mypy-cache'}",
                           *args], capture_output=True, text=True, timeout=300, cwd=str(tmp_path),
                          env=dict(os.environ, MYPYPATH=PACKAGE_SRC))


def test_mypy_strict_is_clean_on_the_package_and_types_its_users(tmp_path):
    assert os.path.isfile(os.path.join(PACKAGE_SRC, "rsdiscovery", "py.typed"))
    r = mypy(tmp_path, os.path.join(PACKAGE_SRC, "rsdiscovery"))
    assert r.returncode == 0, r.stdout + r.stderr
    assert "Success: no issues found" in r.stdout
    # A user's program is checked against the package's types: right use passes, a wrong
    # one is caught (an Optional serial used as a str, a device changed).
    good = tmp_path / "good.py"
    good.write_text("import rsdiscovery\n\n\n"
                    "def serials(domains: list[int]) -> list[str]:\n"
                    "    with rsdiscovery.Client() as c:\n"
                    "        return [d.serial or d.id for d in c.list_devices(domain=domains)]\n\n\n"
                    "def servers() -> list[str]:\n"
                    "    return [p.name for p in rsdiscovery.participants() if p.devices > 0]\n\n\n"
                    "def shared(host: str) -> list[tuple[str, tuple[str, ...]]]:\n"
                    "    return [(d.host.name, d.host.addresses) for d in rsdiscovery.list_devices(host=host)\n"
                    "            if d.host is not None]\n\n\n"
                    "def streamed() -> list[tuple[str, int, tuple[str, ...]]]:\n"
                    "    first = rsdiscovery.wait_for(in_use=True, timeout=5.0)\n"
                    "    with rsdiscovery.Client() as c, c.watcher(in_use=True) as w:\n"
                    "        for ev in rsdiscovery.watch(in_use=False):\n"
                    "            break\n"
                    "        return [(d.id, d.in_use.clients, d.in_use.streaming) for d in w.devices() + [first]\n"
                    "                if d.in_use is not None]\n")
    r = mypy(tmp_path, str(good))
    assert r.returncode == 0, r.stdout + r.stderr
    bad = tmp_path / "bad.py"
    bad.write_text("import rsdiscovery\n\n"
                   "dev = rsdiscovery.get_device('x')\n"
                   "length: int = len(dev.serial)\n"
                   "dev.domain = 3\n"
                   "sharer: str = dev.host.name\n"
                   "clients: int = dev.in_use.clients\n"
                   "rsdiscovery.watch(in_use='yes')\n")
    r = mypy(tmp_path, str(bad))
    assert r.returncode == 1, r.stdout + r.stderr
    errors = [line for line in r.stdout.splitlines() if ": error:" in line]
    assert len(errors) == 5, r.stdout
    assert errors[0].startswith("bad.py:4: error:") and "str | None" in errors[0], r.stdout  # serial may be None
    assert errors[1].startswith("bad.py:5: error:") and "read-only" in errors[1], r.stdout  # frozen
    assert errors[2].startswith("bad.py:6: error:") and "None" in errors[2], r.stdout  # host None unless shared
    assert errors[3].startswith("bad.py:7: error:") and "None" in errors[3], r.stdout  # in_use None unless used
    assert errors[4].startswith("bad.py:8: error:") and "in_use" in errors[4], r.stdout  # a bool, typed
