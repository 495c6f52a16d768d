"""The daemon follows the host's network (issue 21): every change a robot's host
sees in the field, made for real in network namespaces (the daemon's "host" and
one namespace per camera network, joined by veth pairs), with realdds servers
(pyrealsense2, Fast DDS) as the cameras. Each case asserts what a user checks:
the camera on the changed network is listed, without a restart, and cameras on
networks that did not change see no event.

Each case prints the time from the change to the camera listed; with -s the
table shows (the target, 2 s plus the camera's own discovery, is the bench's and
the issue note's, never an assertion here).
"""
import itertools
import json
import os
import queue
import signal
import subprocess
import time

import pytest

from conftest import EventStream, device_info, wait_for
from netns import _run
from test_realdds import LEASE_S, dds_id

CLI = os.path.join(os.environ.get("RSD_BUILD_DIR", ""), "client", "rs-discover")
# How long the lossy-link cases last: short in the suite, 60 s for the issue's table
# (RSD_LOSS_SECONDS=60 ctest -R interop_network_follow -V).
LOSS_SECONDS = float(os.environ.get("RSD_LOSS_SECONDS", "12"))
_serial = itertools.count()
TIMES = []  # (case, seconds from the change to the camera listed)


class Lab:
    """A host namespace and camera namespaces, each camera network a veth pair with
    its own subnet 10.(232+k).N.0/24: host .1, camera .2."""

    def __init__(self):
        self.n = (os.getpid() * 11 + next(_serial)) % 250 + 1
        self.tag = f"rsf{os.getpid() % 100000}x{self.n}"
        self.host = f"{self.tag}h"
        self.namespaces = [self.host]
        _run("ip", "netns", "add", self.host)
        self.exec(self.host, "ip", "link", "set", "lo", "up")

    def prefix(self, ns):
        return ["ip", "netns", "exec", ns]

    def exec(self, ns, *args, input=None):
        return _run(*self.prefix(ns), *args, input=input)

    def subnet(self, k):
        return f"10.{232 + k}.{self.n}"

    def camera_ns(self, name):
        ns = f"{self.tag}{name}"
        _run("ip", "netns", "add", ns)
        self.namespaces.append(ns)
        self.exec(ns, "ip", "link", "set", "lo", "up")
        return ns

    def plug(self, ns, k, host_dev, host_address=True):
        """A veth pair from the host (host_dev) to camera namespace `ns` on subnet k."""
        cam_dev = f"c{host_dev}"
        _run("ip", "link", "add", host_dev, "netns", self.host, "type", "veth", "peer", "name", cam_dev, "netns", ns)
        self.exec(ns, "ip", "addr", "add", f"{self.subnet(k)}.2/24", "dev", cam_dev)
        self.exec(ns, "ip", "link", "set", cam_dev, "up", "multicast", "on")
        # The camera's DDS discovery (multicast 239.255.0.1) leaves by its one link.
        self.exec(ns, "ip", "route", "add", "224.0.0.0/4", "dev", cam_dev)
        self.exec(self.host, "ip", "link", "set", host_dev, "up", "multicast", "on")
        if host_address:
            self.address(host_dev, k)

    def address(self, host_dev, k, remove=False):
        self.exec(self.host, "ip", "addr", "del" if remove else "add", f"{self.subnet(k)}.1/24", "dev", host_dev)
        if not remove:  # as a DHCP lease brings a route with it
            self.exec(self.host, "ip", "route", "replace", "224.0.0.0/4", "dev", host_dev)

    def unplug(self, host_dev):
        self.exec(self.host, "ip", "link", "del", host_dev)

    def destroy(self):
        for ns in self.namespaces:
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)


@pytest.fixture
def lab():
    net = Lab()
    yield net
    net.destroy()


@pytest.fixture(scope="module", autouse=True)
def print_times():
    yield
    if TIMES:
        # RSD_SUITE: the daemon is another release's package (nspawn.py stage).
        print(f"\n{os.environ.get('RSD_SUITE', 'this tree')}'s daemon\n"
              "| case | change -> camera listed |\n| --- | --- |")
        for case, seconds in TIMES:
            print(f"| {case} | {seconds:.2f} s |")


def doctor_network(d, lab):
    """(exit status, the doctor's 'network' findings) run beside the daemon."""
    r = subprocess.run(lab.prefix(lab.host) + [CLI, "--endpoint", "unix:" + d.socket, "doctor", "--json"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode in (0, 1), (r.returncode, r.stdout, r.stderr)
    return r.returncode, [f for f in json.loads(r.stdout)["findings"] if f["topic"] == "network"]


def interfaces(d):
    return {i["name"]: i["addresses"] for i in d.get_json("/v1/domains")["domains"][0]["interfaces"]}


def camera_listed_on_a(free_domain, daemon, realdds_server, lab):
    """One camera network (rsdA, namespace "a") with a realdds camera, and the daemon
    listing it: (daemon, the camera's id, its namespace, its server)."""
    a = lab.camera_ns("a")
    lab.plug(a, 0, "rsdA")
    camera = device_info(1)
    server = realdds_server(free_domain, [camera], prefix=lab.prefix(a))
    d = daemon([free_domain], http=False, prefix=lab.prefix(lab.host))
    cam_id = dds_id(free_domain, camera)
    wait_for(lambda: d.device_ids() == [cam_id], timeout=20, what="the camera")
    return d, cam_id, a, server


def cameras_on_two_networks(free_domain, realdds_server, lab):
    """Two camera networks, rsdA and rsdB, a realdds camera on each: their device-infos."""
    a, b = lab.camera_ns("a"), lab.camera_ns("b")
    lab.plug(a, 0, "rsdA")
    lab.plug(b, 1, "rsdB")
    cam_a, cam_b = device_info(1), device_info(2)
    realdds_server(free_domain, [cam_a], name="server-a", prefix=lab.prefix(a))
    realdds_server(free_domain, [cam_b], name="server-b", prefix=lab.prefix(b))
    return cam_a, cam_b


def listed_after(d, device_id, since, case, timeout=20):
    wait_for(lambda: device_id in d.device_ids(), timeout=timeout, interval=0.05, what=f"{device_id} listed")
    TIMES.append((case, time.monotonic() - since))


def test_daemon_started_before_the_network(free_domain, daemon, realdds_server, lab):
    cams = lab.camera_ns("a")
    lab.plug(cams, 0, "rsdA", host_address=False)  # the DHCP lease has not come yet
    d = daemon([free_domain], http=False, prefix=lab.prefix(lab.host))
    assert list(interfaces(d)) == ["lo"]  # nothing else usable yet
    status, findings = doctor_network(d, lab)
    assert status == 1 and any("loopback only" in f["text"] for f in findings), findings
    camera = device_info(1)
    realdds_server(free_domain, [camera], prefix=lab.prefix(cams))
    since = time.monotonic()
    lab.address("rsdA", 0)  # the lease
    listed_after(d, dds_id(free_domain, camera), since, "daemon started before the network")
    assert interfaces(d) == {"rsdA": [f"{lab.subnet(0)}.1"]}
    status, findings = doctor_network(d, lab)
    assert status == 0 and not [f for f in findings if f["verdict"] in ("warn", "fail")], findings  # healthy
    entry = d.get_json("/v1/domains")["domains"][0]
    assert entry["network-changes"] == 1 and entry["network-changed-at"]
    metrics = d.request("/metrics")[2].decode()
    assert f'rsd_network_changes_total{{domain="{free_domain}"}} 1' in metrics


def test_renumbered_under_the_running_daemon(free_domain, daemon, realdds_server, lab):
    # The site's network moves to a new subnet (a new DHCP scope): the host and the
    # camera's side both get the new address and lose the old one.
    cams = lab.camera_ns("a")
    lab.plug(cams, 0, "rsdA")
    d = daemon([free_domain], http=False, prefix=lab.prefix(lab.host))
    since = time.monotonic()
    lab.exec(lab.host, "ip", "addr", "add", f"{lab.subnet(1)}.1/24", "dev", "rsdA")
    lab.address("rsdA", 0, remove=True)
    lab.exec(cams, "ip", "addr", "add", f"{lab.subnet(1)}.2/24", "dev", "crsdA")
    lab.exec(cams, "ip", "addr", "del", f"{lab.subnet(0)}.2/24", "dev", "crsdA")
    camera = device_info(1)
    realdds_server(free_domain, [camera], prefix=lab.prefix(cams))
    listed_after(d, dds_id(free_domain, camera), since, "renumbered, then a camera starts")
    assert interfaces(d) == {"rsdA": [f"{lab.subnet(1)}.1"]}


def test_two_networks_with_a_camera_on_each(free_domain, daemon, realdds_server, lab):
    cam_a, cam_b = cameras_on_two_networks(free_domain, realdds_server, lab)
    d = daemon([free_domain], http=False, prefix=lab.prefix(lab.host))
    assert sorted(interfaces(d)) == ["rsdA", "rsdB"]
    wait_for(lambda: d.device_ids() == sorted([dds_id(free_domain, cam_a), dds_id(free_domain, cam_b)]),
             timeout=20, what="a camera on each network")
    assert d.get_json("/v1/domains")["domains"][0]["network-changes"] == 0  # nothing changed: no refresh


def test_second_interface_hot_added(free_domain, daemon, realdds_server, lab):
    a = lab.camera_ns("a")
    lab.plug(a, 0, "rsdA")
    cam_a, cam_b = device_info(1), device_info(2)
    realdds_server(free_domain, [cam_a], name="server-a", prefix=lab.prefix(a))
    d = daemon([free_domain], http=False, prefix=lab.prefix(lab.host))
    wait_for(lambda: d.device_ids() == [dds_id(free_domain, cam_a)], timeout=20, what="the first network's camera")
    events = EventStream(d)
    b = lab.camera_ns("b")
    since = time.monotonic()
    lab.plug(b, 1, "rsdB")  # a USB-Ethernet adapter plugged in
    realdds_server(free_domain, [cam_b], name="server-b", prefix=lab.prefix(b))
    listed_after(d, dds_id(free_domain, cam_b), since, "second interface hot-added")
    assert sorted(interfaces(d)) == ["rsdA", "rsdB"]
    # The first network's camera never left: the refresh is invisible, through the
    # reconciliation that follows it (2 s after the new reader) too.
    end = time.monotonic() + 3.0
    while time.monotonic() < end:
        assert dds_id(free_domain, cam_a) in d.device_ids()
        time.sleep(0.05)
    events.close()
    seen = []
    while not events.events.empty():
        ev = events.events.get()
        if ev and ev.get("event") in ("added", "removed"):
            seen.append((ev["event"], ev.get("json", {}).get("id")))
    assert seen == [("added", dds_id(free_domain, cam_b))], seen


def test_unplugged_and_plugged_again(free_domain, daemon, realdds_server, lab):
    d, cam_id, a, server = camera_listed_on_a(free_domain, daemon, realdds_server, lab)
    unplugged = time.monotonic()
    lab.unplug("rsdA")  # both ends of the pair go
    wait_for(lambda: d.device_ids() == [], timeout=LEASE_S + 5, what="the camera gone with its network")
    gone_after = time.monotonic() - unplugged
    assert list(interfaces(d)) == ["lo"]
    # It left with its interface: the daemon joined anew on what is left and did not
    # hear it there, before its server's lease could run out on the old participant.
    status, _, body = d.request(f"/v1/devices/{cam_id}")
    assert status == 410, (status, body)
    assert json.loads(body)["gone"]["reason"] == "interface-gone", body
    print(f"\nunplugged -> removed (interface-gone) in {gone_after:.2f} s")
    server.kill()  # Fast DDS does not follow interfaces either: the camera restarts with its network
    since = time.monotonic()
    lab.plug(a, 0, "rsdA")
    realdds_server(free_domain, [device_info(1)], prefix=lab.prefix(a))
    listed_after(d, cam_id, since, "adapter unplugged and plugged again")


def test_link_down_and_up(free_domain, daemon, realdds_server, lab):
    d, cam_id, _, _ = camera_listed_on_a(free_domain, daemon, realdds_server, lab)
    lab.exec(lab.host, "ip", "link", "set", "rsdA", "down")
    wait_for(lambda: d.device_ids() == [], timeout=LEASE_S + 5, what="the camera gone while the link is down")
    since = time.monotonic()
    lab.exec(lab.host, "ip", "link", "set", "rsdA", "up")
    listed_after(d, cam_id, since, "link down, then up")


def test_container_bridge_is_left_out(free_domain, daemon, realdds_server, lab):
    a = lab.camera_ns("a")
    lab.plug(a, 0, "rsdA")
    # A docker0 with a container attached: up, carrier, multicast, an address.
    lab.exec(lab.host, "ip", "link", "add", "docker0", "type", "bridge")
    lab.exec(lab.host, "ip", "link", "add", "vethc0", "type", "veth", "peer", "name", "vethc1")
    lab.exec(lab.host, "ip", "link", "set", "vethc0", "master", "docker0")
    for dev in ("docker0", "vethc0", "vethc1"):
        lab.exec(lab.host, "ip", "link", "set", dev, "up")
    lab.exec(lab.host, "ip", "addr", "add", "172.17.0.1/16", "dev", "docker0")
    camera = device_info(1)
    realdds_server(free_domain, [camera], prefix=lab.prefix(a))
    d = daemon([free_domain], http=False, prefix=lab.prefix(lab.host))
    assert list(interfaces(d)) == ["rsdA"]
    wait_for(lambda: d.device_ids() == [dds_id(free_domain, camera)], timeout=20, what="the camera")


def test_explicit_interface_not_there_yet(free_domain, daemon, realdds_server, lab):
    a = lab.camera_ns("a")
    lab.plug(a, 0, "rsdA")
    cam_a, cam_b = device_info(1), device_info(2)
    realdds_server(free_domain, [cam_a], name="server-a", prefix=lab.prefix(a))
    d = daemon([free_domain], http=False, prefix=lab.prefix(lab.host), extra=["--interface", "rsdB"])
    assert list(interfaces(d)) == ["lo"]  # rsdA is not named: never joined
    # The doctor names the server on a network the daemon was told to stay off.
    status, findings = doctor_network(d, lab)
    assert status == 1 and any("server-a" in f["text"] and "--interface rsdA" in f["text"] for f in findings), findings
    b = lab.camera_ns("b")
    since = time.monotonic()
    lab.plug(b, 1, "rsdB")  # the named adapter appears
    realdds_server(free_domain, [cam_b], name="server-b", prefix=lab.prefix(b))
    listed_after(d, dds_id(free_domain, cam_b), since, "explicit interface appears")
    assert list(interfaces(d)) == ["rsdB"]
    assert dds_id(free_domain, cam_a) not in d.device_ids()


def test_a_flapping_address_is_backed_off(free_domain, daemon, realdds_server, lab):
    # A bad DHCP server: the host's address changes every half second for 10 s.
    d, cam_id, _, _ = camera_listed_on_a(free_domain, daemon, realdds_server, lab)
    flaps, current = 0, None
    end = time.monotonic() + 10
    while time.monotonic() < end:  # making the flaps, not waiting for anything
        address = f"{lab.subnet(0)}.{5 + flaps % 2}/24"
        lab.exec(lab.host, "ip", "addr", "add", address, "dev", "rsdA")
        if current:
            lab.exec(lab.host, "ip", "addr", "del", current, "dev", "rsdA")
        current = address
        flaps += 1
        time.sleep(0.5)
    changes = d.get_json("/v1/domains")["domains"][0]["network-changes"]
    print(f"{flaps} address changes in 10 s: {changes} refreshes")
    # Spaced 1, 2, 4, 8 s apart: a handful, not one per change.
    assert 1 <= changes <= 6, changes
    # Once it settles, the camera is there.
    wait_for(lambda: cam_id in d.device_ids(), timeout=40, what="the camera after the flapping")


def test_reload_applies_a_changed_interface_list(free_domain, daemon, realdds_server, lab, tmp_path):
    cam_a, cam_b = cameras_on_two_networks(free_domain, realdds_server, lab)
    config = tmp_path / "config.json"
    config.write_text(json.dumps({"interfaces": ["rsdB"]}))
    d = daemon([free_domain], http=False, prefix=lab.prefix(lab.host), extra=["--config", str(config)])
    wait_for(lambda: d.device_ids() == [dds_id(free_domain, cam_b)], timeout=20, what="rsdB's camera alone")
    assert list(interfaces(d)) == ["rsdB"]
    config.write_text(json.dumps({"interfaces": ["rsd*"]}))
    since = time.monotonic()
    d.proc.send_signal(signal.SIGHUP)
    listed_after(d, dds_id(free_domain, cam_a), since, "reload widens the interface list")
    assert sorted(interfaces(d)) == ["rsdA", "rsdB"]


def cpu_seconds(pid):
    """User plus system CPU time of process `pid` so far."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@pytest.mark.parametrize("percent", [20, 50])
def test_a_lossy_link_is_ridden_out(percent, free_domain, daemon, realdds_server, lab):
    # A bad Wi-Fi bridge or a congested switch: random loss of the camera's UDP
    # both ways. The kernel sees no change, so no netlink event and no refresh.
    # What gets through renews the server's lease (3 s); at 50 % a lease can run
    # out (3 s with nothing through happens), and then the camera is looked for
    # again and listed once traffic passes. Either way the daemon spends next to
    # nothing, and the camera is listed when the link is good again.
    d, cam_id, a, _ = camera_listed_on_a(free_domain, daemon, realdds_server, lab)
    events = EventStream(d)
    cpu0 = cpu_seconds(d.proc.pid)
    rule = f"meta l4proto udp numgen random mod 100 < {percent} drop"
    lab.exec(a, "nft", "-f", "-", input=(
        "table inet rsdloss {\n"
        f"  chain in {{ type filter hook input priority -10; iifname \"crsdA\" {rule}; }}\n"
        f"  chain out {{ type filter hook output priority -10; oifname \"crsdA\" {rule}; }}\n"
        "}\n"))
    changes = []  # what a watcher saw while the link was lossy
    gaps, removed_at = [], None  # how long the camera was missing each time
    end = time.monotonic() + LOSS_SECONDS
    while (left := end - time.monotonic()) > 0:
        try:
            ev = events.events.get(timeout=left)
        except queue.Empty:
            break
        if ev and ev.get("event") in ("added", "removed", "updated"):
            changes.append(ev["event"])
            if ev["event"] == "removed":
                removed_at = time.monotonic()
            elif ev["event"] == "added" and removed_at is not None:
                gaps.append(time.monotonic() - removed_at)
                removed_at = None
    lab.exec(a, "nft", "delete", "table", "inet", "rsdloss")
    cpu = cpu_seconds(d.proc.pid) - cpu0
    since = time.monotonic()
    # Bounded by the lease, the longest back-off between refreshes (30 s) and a
    # refresh's settle time.
    wait_for(lambda: d.device_ids() == [cam_id], timeout=LEASE_S + 40, interval=0.05, what="the camera after the loss")
    back = time.monotonic() - since
    events.close()
    entry = d.get_json("/v1/domains")["domains"][0]
    print(f"{percent} % loss for {LOSS_SECONDS:.0f} s: {changes.count('removed')} removals "
          f"(missing for {', '.join(f'{g:.1f}' for g in gaps) or '-'} s), "
          f"{entry['network-changes']} network refreshes, {cpu:.2f} CPU-s, listed {back:.2f} s after")
    assert entry["network-changes"] == 0  # loss is not a network change
    assert cpu < 0.05 * LOSS_SECONDS  # well under 5 % of a core (measured ~0.1 %)
