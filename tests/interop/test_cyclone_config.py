"""The `cyclonedds-config` setting hands users Cyclone DDS's own network knobs
(interface, multicast off, unicast peers): how cameras beyond the subnet are
reached, with DDS's mechanisms and nothing home-made."""
import json
import os
import subprocess

from conftest import DAEMON, device_info, free_port, wait_for

UNICAST_ONLY = """<CycloneDDS><Domain>
  <General><Interfaces><NetworkInterface name="{ifname}"/></Interfaces><AllowMulticast>false</AllowMulticast></General>
  <Discovery><Peers><Peer address="{address}"/></Peers><ParticipantIndex>auto</ParticipantIndex></Discovery>
</Domain></CycloneDDS>"""


def global_ipv4():
    """This machine's first non-loopback IPv4 interface and address. Fast DDS
    ignores loopback locators from a participant it takes for another host's,
    so unicast discovery is shown on a real interface, as users would use it."""
    out = subprocess.run(["ip", "-4", "-o", "addr", "show", "scope", "global"], capture_output=True, text=True,
                         check=True).stdout.split()
    assert "inet" in out, "no global IPv4 address on this machine"
    return out[1], out[out.index("inet") + 1].split("/")[0]


def test_unicast_peer_without_multicast_finds_the_camera(free_domain, daemon, realdds_server, tmp_path):
    info = device_info(1)
    realdds_server(free_domain, [info])
    config = tmp_path / "rs-discoveryd.json"
    ifname, address = global_ipv4()
    config.write_text(json.dumps({"cyclonedds-config": UNICAST_ONLY.format(ifname=ifname, address=address)}))
    d = daemon([free_domain], extra=["--config", str(config)])
    wait_for(lambda: [dev["serial"] for dev in d.devices()] == [info["serial"]], timeout=15,
             what="the camera found over unicast discovery")


def test_broken_cyclone_config_is_a_clear_error(tmp_path):
    sock = str(tmp_path / "api.sock")
    r = subprocess.run([DAEMON, "--domain", "3", "--socket", sock, "--http", f"127.0.0.1:{free_port()}",
                        "--no-usb", "--cyclonedds-config", "<CycloneDDS><Domain><Bogus>1</Bogus>"],
                       capture_output=True, text=True, timeout=20)
    assert r.returncode == 1
    assert "cannot create DDS domain 3" in r.stderr and "cyclonedds" in r.stderr
    assert not os.path.exists(sock)
