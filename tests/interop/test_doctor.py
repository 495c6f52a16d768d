"""`rs-discover doctor` on networks broken the usual ways (issue 13), reproduced with
network namespaces and nftables: a realdds server on another "host" behind a firewall
that lets discovery multicast in but drops the unicast exchange; one whose first
announcement gets through and nothing after; a host firewall dropping UDP from the
camera's network (those three with nftables); a host with no multicast route; a camera
server on another DDS domain (found by listening to every domain's discovery port).
Each time the doctor must name the cause (and exit 1). On healthy networks (issue 23) it
must say nothing is wrong (exit 0): with short-lived DDS programs coming and going
(librealsense's own query_devices(), a camera server that ran 4 s), with multi-homed
servers and hosts, with a link-local address beside a routable one; and as a user who
may not use the socket it names the group to join or the HTTP endpoint, not "start it"."""
import grp
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import pytest
from conftest import device_info, wait_for
from netns import TwoHosts

CLI = os.path.join(os.environ.get("RSD_BUILD_DIR", ""), "client", "rs-discover")


@pytest.fixture
def net():
    hosts = TwoHosts()
    yield hosts
    hosts.destroy()


def doctor(d, net=None, *args):
    """(exit status, findings) of the doctor run beside the daemon (in its namespace)."""
    prefix = net.prefix(net.host) if net else []
    r = subprocess.run(prefix + [CLI, "--endpoint", "unix:" + d.socket, "doctor", "--json", *args],
                       capture_output=True, text=True, timeout=60)
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
    # Asked about the camera itself: listed, and free (no client).
    status, findings = doctor(d, net, camera["serial"])
    assert status == 0, findings
    assert said(findings, "ok", "camera", camera["serial"], "is listed")
    assert said(findings, "ok", "in-use", "has no client: it is free")


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


def test_cameras_on_another_domain(domains, daemon, realdds_server, net):
    # The most common reason a camera is missing: its server is on another domain.
    # The doctor listens to every domain's discovery port and names who is there.
    mine, theirs = domains.take(), domains.take()
    realdds_server(theirs, [device_info(5)], name="elsewhere-server", prefix=net.prefix(net.camera))
    d = daemon([mine], http=False, prefix=net.prefix(net.host))
    status, findings = doctor(d, net)
    assert status == 1, findings
    assert said(findings, "warn", "network", f"nobody else is heard on domain {mine}", "another domain")
    assert said(findings, "warn", "domains", f"on domain {theirs}", "'elsewhere-server'", net.camera_ip,
                f"the daemon listens on {mine}", f"--domain {theirs}"), findings
    assert said(findings, "ok", "domains", f"DDS domain {mine} (running)")
    assert said(findings, "info", "domains", "domain 0 is not among them")


def test_a_server_on_the_daemons_domain_is_not_named_as_elsewhere(free_domain, daemon, realdds_server, net):
    realdds_server(free_domain, [device_info(9)], name="right-here-server", prefix=net.prefix(net.camera))
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")
    status, findings = doctor(d, net)
    assert status == 0, findings
    ok = said(findings, "ok", "domains", "nothing else announces itself")
    assert ok, "\n".join(f"{f['verdict']} {f['topic']}: {f['text']}" for f in findings)  # in full, not cut
    # Each of the 233 domains' discovery ports, but for one that another socket here
    # happens to hold: a DDS participant's unicast ports are random, and 113 of the
    # 28,232 ephemeral ports are domains' discovery ports.
    listened = int(re.search(r"any of the (\d+) domains", ok[0]["text"]).group(1))
    assert 230 <= listened <= 233, ok


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


def test_a_link_local_address_beside_a_routable_one_is_only_info(free_domain, daemon, realdds_server, net):
    # The camera's host has a link-local address besides the test network's: the daemon
    # hears it by the routable one, so it explains no missing camera (issue 23).
    net.exec(net.camera, "ip", "addr", "add", "169.254.23.2/16", "dev", "rsdv1")
    realdds_server(free_domain, [device_info(8)], name="autoip-server", prefix=net.prefix(net.camera))
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))
    wait_for(lambda: len(d.devices()) == 1, 20, what="the camera")

    def named():
        status, findings = doctor(d, net)
        return status == 0 and said(findings, "info", "addresses", "'autoip-server'", "link-local", "DHCP")
    wait_for(named, 20, interval=0.5, what="the doctor naming the link-local address as info")


def not_ok(findings):
    return [f for f in findings if f["verdict"] in ("warn", "fail")]


LIBREALSENSE_QUERY = ("import sys, pyrealsense2 as rs; "
                      "rs.context({'dds': {'enabled': True, 'domain': int(sys.argv[1])}}).query_devices()")


def test_short_lived_dds_programs_raise_no_alarm(free_domain, daemon, realdds_server, net):
    # librealsense's own query_devices() (a participant for about 3 s, its lease) and a
    # camera server that ran 4 s with its camera listed both leave cleanly: the
    # doctor must not take them for participants a firewall cut off (issue 23).
    realdds_server(free_domain, [device_info(10)], name="steady-server", prefix=net.prefix(net.camera))
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))
    wait_for(lambda: len(d.devices()) == 1, 20, what="the steady camera")

    def gone(name):
        return [p for p in d.get_json("/v1/participants?state=gone")["participants"] if p["name"] == name]

    subprocess.run(net.prefix(net.camera) + [sys.executable, "-c", LIBREALSENSE_QUERY, str(free_domain)],
                   check=True, timeout=60, capture_output=True)
    brief_camera = device_info(11)
    brief = realdds_server(free_domain, [brief_camera], name="brief-server", prefix=net.prefix(net.camera))
    started = time.monotonic()
    wait_for(lambda: brief_camera["serial"] in [x["serial"] for x in d.devices()], 20, what="the brief camera")
    time.sleep(max(0.0, 4.0 - (time.monotonic() - started)))  # it ran 4 s, as in the issue
    brief.quit()
    wait_for(lambda: gone("brief-server"), 20, what="the brief server gone")
    query = [p for p in d.get_json("/v1/participants?state=gone")["participants"]
             if p["name"] not in ("brief-server",) and p["vendor"] == "fast-dds"]
    assert query, "librealsense's query participant was heard and went"
    status, findings = doctor(d, net)
    assert status == 0 and not not_ok(findings), findings
    assert said(findings, "ok", "network", "1 participant heard, 1 announcing")


def test_multi_homed_servers_and_hosts_are_counted_per_participant(free_domain, daemon, realdds_server, net):
    # A second network between the two hosts: the server announces both addresses,
    # and it is on the network discovery multicast leaves by (rsdv0) as well. And a
    # host interface without multicast (as a VPN's tun0): nothing a camera needs.
    n = net.host_ip.split(".")[2]
    net.exec(net.host, "ip", "link", "add", "rsdw0", "type", "veth", "peer", "name", "rsdw1", "netns", net.camera)
    for ns, dev, ip in ((net.host, "rsdw0", f"10.232.{n}.1/24"), (net.camera, "rsdw1", f"10.232.{n}.2/24")):
        net.exec(ns, "ip", "addr", "add", ip, "dev", dev)
        net.exec(ns, "ip", "link", "set", dev, "up")
    # Fast DDS takes the interfaces that are up (with carrier) when it starts.
    wait_for(lambda: " UP " in net.exec(net.camera, "ip", "-br", "link", "show", "rsdw1"), 10, what="rsdw1 up")
    net.exec(net.host, "ip", "link", "add", "rsdt0", "type", "veth", "peer", "name", "rsdt1")
    net.exec(net.host, "ip", "addr", "add", f"10.233.{n}.1/24", "dev", "rsdt0")
    for dev in ("rsdt0", "rsdt1"):
        net.exec(net.host, "ip", "link", "set", dev, "up", "multicast", "off")
    realdds_server(free_domain, [device_info(12)], name="two-homed-server", prefix=net.prefix(net.camera))
    realdds_server(free_domain, [device_info(13)], name="other-server", prefix=net.prefix(net.camera))
    d = daemon([free_domain], http=False, prefix=net.prefix(net.host))
    wait_for(lambda: len(d.devices()) == 2, 20, what="both cameras")

    def both_addresses():
        ps = [p for p in d.get_json("/v1/participants")["participants"] if p["name"] == "two-homed-server"]
        return ps and {net.camera_ip, f"10.232.{n}.2"} <= set(ps[0]["addresses"])
    wait_for(both_addresses, 10, what="the server announcing both addresses")
    status, findings = doctor(d, net)
    assert status == 0 and not not_ok(findings), findings
    assert not said(findings, "info", "interface", "rsdw0"), findings
    assert said(findings, "info", "multicast", "rsdt0", "does not do multicast")


def test_a_user_without_socket_rights_is_told_the_group_or_http(daemon, free_domain, tmp_path):
    # The daemon runs; `nobody` may not use its socket (mode 0660, group `users`).
    # The doctor must say so and what to do, not tell them to start it (issue 23).
    run_dir = tempfile.mkdtemp(prefix="rsd-doctor-")
    os.chmod(run_dir, 0o755)
    try:
        sock = os.path.join(run_dir, "api.sock")
        d = daemon([free_domain], socket=sock)
        os.chown(sock, 0, grp.getgrnam("users").gr_gid)
        r = subprocess.run(["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups", CLI, "--endpoint",
                            "unix:" + sock, "doctor", "--json"], capture_output=True, text=True, timeout=30)
        assert r.returncode == 3, (r.returncode, r.stdout, r.stderr)
        findings = json.loads(r.stdout)["findings"]
        line = said(findings, "fail", "daemon", "permission denied", "join group users", "usermod -aG users nobody",
                    "--endpoint http://")
        assert line, findings
        assert "start it" not in line[0]["text"]
        assert d.healthy()
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)


def test_a_root_owned_socket_is_never_a_group_to_join(daemon, free_domain):
    # The daemon run as root from the tree: its socket is root:root 0660. Joining root
    # would give far more than the socket; the doctor says how to give it a group of its
    # own, and names the HTTP address this daemon really listens on (not the default).
    run_dir = tempfile.mkdtemp(prefix="rsd-doctor-")
    os.chmod(run_dir, 0o755)
    try:
        sock = os.path.join(run_dir, "api.sock")
        d = daemon([free_domain], socket=sock)
        st = os.stat(sock)
        assert (st.st_uid, st.st_gid, st.st_mode & 0o777) == (0, 0, 0o660)
        r = subprocess.run(["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups", CLI, "--endpoint",
                            "unix:" + sock, "doctor", "--json"], capture_output=True, text=True, timeout=30)
        assert r.returncode == 3, (r.returncode, r.stdout, r.stderr)
        (line,) = said(json.loads(r.stdout)["findings"], "fail", "daemon", "permission denied")
        text = line["text"]
        assert "join group root" not in text and "usermod -aG root" not in text, text
        assert "its group root grants much more than this socket: do not join it" in text, text
        assert "give the socket a group of its own" in text and "SocketGroup=" in text, text
        assert "--socket-group GROUP" in text, text  # the way for a daemon run by hand
        assert f"'rs-discover --endpoint http://127.0.0.1:{d.port} doctor' (it answers there)" in text, text
        assert "127.0.0.1:8035" not in text or d.port == 8035, text
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)
