"""Two test hosts on one machine: network namespaces joined by a veth pair, so a
realdds server can sit on another "host" and the link between them can be cut.

Cuts are nftables drop rules in the server's namespace (the link stays up, as
with a failed switch port or a pulled cable further along): what the field sees
when a camera's network goes away for a while. `ip link set down` also drops
multicast memberships and is a different failure.
"""
import itertools
import os
import subprocess

import pytest

_serial = itertools.count()


def _run(*args, input=None):
    r = subprocess.run(list(args), input=input, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(args)}: {r.stderr.strip()}")
    return r.stdout


class TwoHosts:
    """Namespaces `host` and `camera`, 10.231.N.1 and 10.231.N.2 on a veth pair."""

    def __init__(self):
        n = (os.getpid() * 7 + next(_serial)) % 250 + 1
        tag = f"rsd{os.getpid() % 100000}x{n}"
        self.host, self.camera = f"{tag}h", f"{tag}c"
        self.host_ip, self.camera_ip = f"10.231.{n}.1", f"10.231.{n}.2"
        self.cut_active = False
        _run("ip", "netns", "add", self.host)
        try:
            _run("ip", "netns", "add", self.camera)
            _run("ip", "link", "add", "rsdv0", "netns", self.host, "type", "veth", "peer", "name", "rsdv1", "netns",
                 self.camera)
            for ns, dev, ip in ((self.host, "rsdv0", self.host_ip), (self.camera, "rsdv1", self.camera_ip)):
                self.exec(ns, "ip", "link", "set", "lo", "up")
                self.exec(ns, "ip", "addr", "add", f"{ip}/24", "dev", dev)
                self.exec(ns, "ip", "link", "set", dev, "up", "multicast", "on")
                # DDS discovery is multicast (239.255.0.1): route it over the link.
                self.exec(ns, "ip", "route", "add", "224.0.0.0/4", "dev", dev)
        except Exception:
            self.destroy()
            raise

    def prefix(self, ns):
        """The command prefix that runs a program inside namespace `ns`."""
        return ["ip", "netns", "exec", ns]

    def exec(self, ns, *args, input=None):
        return _run(*self.prefix(ns), *args, input=input)

    def cut(self):
        """Drops everything on the camera's link, both ways; the link stays up."""
        self.exec(self.camera, "nft", "-f", "-", input=(
            "table inet rsdcut {\n"
            "  chain in { type filter hook input priority -10; iifname \"rsdv1\" drop; }\n"
            "  chain out { type filter hook output priority -10; oifname \"rsdv1\" drop; }\n"
            "}\n"))
        self.cut_active = True

    def heal(self):
        self.exec(self.camera, "nft", "delete", "table", "inet", "rsdcut")
        self.cut_active = False

    def lose(self, percent):
        """Drops `percent` % of the UDP packets on the camera's link, each way, at
        random (nftables numgen): a lossy link, not a cut."""
        self.exec(self.camera, "nft", "-f", "-", input=(
            "table inet rsdloss {\n"
            f"  chain in {{ type filter hook input priority -10; iifname \"rsdv1\" meta l4proto udp "
            f"numgen random mod 100 < {int(percent)} drop; }}\n"
            f"  chain out {{ type filter hook output priority -10; oifname \"rsdv1\" meta l4proto udp "
            f"numgen random mod 100 < {int(percent)} drop; }}\n"
            "}\n"))

    def unlose(self):
        self.exec(self.camera, "nft", "delete", "table", "inet", "rsdloss")

    def destroy(self):
        for ns in (self.host, self.camera):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)


@pytest.fixture
def two_hosts():
    """A fixture: the two hosts, destroyed after the test."""
    net = TwoHosts()
    yield net
    net.destroy()


class Lan:
    """`n` test hosts on one switch: a namespace each (10.232.N.1..n on interface
    `rsdl0`), joined by a bridge in a namespace of its own, so that every daemon
    sees every other one as over a real LAN (multicast discovery included).

    `prefix(i, hostname)` runs a program on host i with its own host name (a UTS
    namespace): the name a daemon gives its shared cameras."""

    def __init__(self, n):
        k = (os.getpid() * 11 + next(_serial)) % 250 + 1
        tag = f"rsd{os.getpid() % 100000}l{k}"
        self.switch = f"{tag}s"
        self.hosts = [f"{tag}h{i}" for i in range(n)]
        self.ips = [f"10.232.{k}.{i + 1}" for i in range(n)]
        _run("ip", "netns", "add", self.switch)
        try:
            self.exec(self.switch, "ip", "link", "add", "br0", "type", "bridge", "mcast_snooping", "0")
            self.exec(self.switch, "ip", "link", "set", "br0", "up")
            for i, (ns, ip) in enumerate(zip(self.hosts, self.ips)):
                _run("ip", "netns", "add", ns)
                _run("ip", "link", "add", "rsdl0", "netns", ns, "type", "veth", "peer", "name", f"p{i}", "netns",
                     self.switch)
                self.exec(self.switch, "ip", "link", "set", f"p{i}", "master", "br0", "up")
                self.exec(ns, "ip", "link", "set", "lo", "up")
                self.exec(ns, "ip", "addr", "add", f"{ip}/24", "dev", "rsdl0")
                self.exec(ns, "ip", "link", "set", "rsdl0", "up", "multicast", "on")
                self.exec(ns, "ip", "route", "add", "224.0.0.0/4", "dev", "rsdl0")
        except Exception:
            self.destroy()
            raise

    def exec(self, ns, *args, input=None):
        return _run("ip", "netns", "exec", ns, *args, input=input)

    def prefix(self, i, hostname=None):
        p = ["ip", "netns", "exec", self.hosts[i]]
        if hostname:
            p += ["unshare", "--uts", "sh", "-c", 'hostname "$0" && exec "$@"', hostname]
        return p

    def destroy(self):
        for ns in self.hosts + [self.switch]:
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)
