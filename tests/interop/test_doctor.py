"""`rs-discover doctor` on networks broken the usual ways (issue 13), reproduced with
network namespaces and nftables: a realdds server on another "host" behind a firewall
that lets discovery multicast in but drops the unicast exchange; one whose first
announcement gets through and nothing after; a host firewall dropping UDP from the
camera's network (those three with nftables); a host with no multicast route; cameras on another
DDS domain. Each time the doctor must name the cause (and exit 1), and on
the healthy network say nothing is wrong (exit 0)."""
import json
import os
import subprocess

import pytest
from conftest import device_info, wait_for
from netns import TwoHosts

CLI = os.path.join(os.environ.get("RSD_BUILD_DIR", ""), "client", "rs-discover")


@pytest.fixture
def net():
    hosts = TwoHosts()
    yield hosts
    hosts.destroy()


def doctor(d, net=None):
    """(exit status, findings) of the doctor run beside the daemon (in its namespace)."""
    prefix = net.prefix(net.host) if net else []
    r = subprocess.run(prefix + [CLI, "--endpoint", "unix:" + d.socket, "doctor", "--json"], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode in (0, 1), (r.returncode, r.stdout, r.stderr)
    return r.returncode, json.loads(r.stdout)["findings"]


def said(findings, verdict, topic, *words):
    return [f for f in findings if f["verdict"] == verdict and f["topic"] == topic and all(w in f["text"] for w in words)]


def firewall(net, rules):
    net.exec(net.camera, "nft", "-f", "-", input="table inet rsdfw {\n" + rules + "}\n")


def test_a_healthy_network_is_all_ok(free_domain, daemon, realdds_server, net):
    camera = device_info(1)
    realdds_server(free_domain, [camera], name="camera-server", prefix=net.prefix(net.camera))
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    status, findings = doctor(d, net)
    assert status == 0, findings
    assert said(findings, "ok", "network", "1 participant heard, 1 announcing")
    assert said(findings, "ok", "multicast", "rsdv0")


def test_unicast_blocked_by_a_firewall(free_domain, daemon, realdds_server, net):
    # Discovery multicast passes; every other UDP packet on the camera's link is dropped.
    firewall(net, """
      chain in { type filter hook input priority -10;
                 iifname "rsdv1" ip daddr 224.0.0.0/4 accept; iifname "rsdv1" meta l4proto udp drop; }
      chain out { type filter hook output priority -10;
                  oifname "rsdv1" ip daddr 224.0.0.0/4 accept; oifname "rsdv1" meta l4proto udp drop; }
    """)
    realdds_server(free_domain, [device_info(2)], name="walled-server", prefix=net.prefix(net.camera))
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))

    def blamed():
        status, findings = doctor(d, net)
        return status == 1 and said(findings, "fail", "firewall", "'walled-server'", net.camera_ip,
                                    "exchanged nothing", f"UDP {7400 + 250 * free_domain}")
    wait_for(blamed, 30, interval=1.0, what="the doctor blaming the firewall")
    assert d.devices() == []


def test_heard_once_then_never_again(free_domain, daemon, realdds_server, net):
    # A firewall letting the first discovery packet through and nothing after it.
    firewall(net, """
      chain out { type filter hook output priority -10;
                  oifname "rsdv1" ip daddr 224.0.0.0/4 limit rate over 1/hour burst 1 packets drop;
                  oifname "rsdv1" ip daddr != 224.0.0.0/4 meta l4proto udp drop; }
      chain in { type filter hook input priority -10; iifname "rsdv1" meta l4proto udp drop; }
    """)
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))
    realdds_server(free_domain, [device_info(3)], name="flaky-server", prefix=net.prefix(net.camera))

    def blamed():
        status, findings = doctor(d, net)
        return status == 1 and said(findings, "warn", "firewall", "'flaky-server'", "heard once and lost after its lease")
    wait_for(blamed, 30, interval=1.0, what="the doctor naming the participant heard once")


def test_udp_from_the_cameras_network_dropped_on_this_host(free_domain, daemon, realdds_server, net):
    # The daemon's host drops every UDP packet from the camera's link (a host firewall).
    # Dropping only the domain's ports is not enough to hide a camera: the daemon's
    # Cyclone DDS also receives unicast on a port of its own choosing (measured).
    net.exec(net.host, "nft", "-f", "-", input=(
        "table inet rsdfw {\n"
        "  chain in { type filter hook input priority -10; iifname \"rsdv0\" meta l4proto udp drop; }\n"
        "}\n"))
    realdds_server(free_domain, [device_info(6)], name="dropped-server", prefix=net.prefix(net.camera))
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))
    base = 7400 + 250 * free_domain
    status, findings = doctor(d, net)
    assert status == 1, [f["text"] for f in findings if f["topic"] in ("network", "firewall")]
    assert said(findings, "warn", "network", f"nobody else is heard on domain {free_domain}",
                f"a firewall drops UDP {base}-{base + 249}")
    assert d.devices() == []


def test_no_multicast_route(free_domain, daemon, realdds_server, net):
    net.exec(net.host, "ip", "route", "del", "224.0.0.0/4", "dev", "rsdv0")
    realdds_server(free_domain, [device_info(4)], name="unreached-server", prefix=net.prefix(net.camera))
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))
    status, findings = doctor(d, net)
    assert status == 1
    assert said(findings, "warn", "multicast", "no route for multicast 239.255.0.1", "ip route add 224.0.0.0/4 dev rsdv0")


def test_cameras_on_another_domain(domains, daemon, realdds_server):
    mine, theirs = domains.take(), domains.take()
    realdds_server(theirs, [device_info(5)], name="elsewhere-server")
    d = daemon([mine])
    status, findings = doctor(d)
    assert status == 1
    assert said(findings, "warn", "network", f"nobody else is heard on domain {mine}", "another domain")
    assert said(findings, "ok", "domains", f"DDS domain {mine} (running)")
    assert said(findings, "info", "domains", "domain 0 is not among them")


def test_one_topic_root_from_two_servers(free_domain, daemon, realdds_server):
    camera = device_info(7)
    realdds_server(free_domain, [camera], name="first-server")
    realdds_server(free_domain, [camera], name="second-server")
    d = daemon([free_domain])

    def blamed():
        status, findings = doctor(d)
        return status == 1 and said(findings, "fail", "topic-root", camera["topic-root"], "announced by 2 servers",
                                    "'first-server'", "'second-server'")
    wait_for(blamed, 20, interval=0.5, what="the doctor naming the two servers")


def test_a_link_local_address_is_named(free_domain, daemon, realdds_server, net):
    # The camera's host got no address from DHCP: it has only a link-local one beside
    # (here besides the test network's, so the daemon still hears it).
    net.exec(net.camera, "ip", "addr", "add", "169.254.23.2/16", "dev", "rsdv1")
    realdds_server(free_domain, [device_info(8)], name="autoip-server", prefix=net.prefix(net.camera))
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))

    def named():
        status, findings = doctor(d, net)
        return status == 1 and said(findings, "warn", "addresses", "'autoip-server'", "link-local", "DHCP")
    wait_for(named, 20, interval=0.5, what="the doctor naming the link-local address")
