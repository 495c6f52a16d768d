"""Who is on the network, in the clients (issue 13): `rs-discover participants`, the C++
library's participants() and Python's participants(), each against the real daemon with
a real realdds server (Fast DDS) on its domain; what each shows is the daemon's own
answer, checked against what the server is."""
import json
import os
import subprocess
import sys

import pytest
from client_util import DOMAIN_RANGE, DRIVER, SOURCE, rs_discover
from conftest import device_info, wait_for
from test_cli import table

sys.path.insert(0, os.path.join(SOURCE, "client", "python", "src"))
import rsdiscovery  # noqa: E402  (the package as shipped)


def steady(answer):
    """An answer without the one key that moves with time: an alive one's last-seen is now."""
    return [{k: v for k, v in p.items() if k != "last-seen"} for p in answer]


@pytest.fixture
def network(daemon, realdds_server, domains):
    """(daemon, domain, server) with a realdds server announcing two cameras."""
    domain = domains.take(*DOMAIN_RANGE)
    server = realdds_server(domain, [device_info(1), device_info(2)], name="bench-server")
    d = daemon([domain])
    wait_for(lambda: len(d.devices()) == 2, 20, what="the two cameras")
    wait_for(lambda: any(p["name"] == "bench-server" for p in d.get_json("/v1/participants")["participants"]),
             what="the server among the participants")
    return d, domain, server


def test_cli_table_json_and_all(network):
    d, domain, server = network
    ep = "unix:" + d.socket
    r = rs_discover("participants", endpoint=ep)
    assert r.returncode == 0, r.stderr
    names, rows = table(r.stdout)
    assert names == ["DOMAIN", "NAME", "VENDOR", "ADDRESSES", "STATE", "DEVICES", "LEASE", "SEEN", "GUID"]
    row = next(x for x in rows if x["NAME"] == "bench-server")
    assert row["DOMAIN"] == str(domain) and row["VENDOR"] == "fast-dds" and row["STATE"] == "alive"
    assert row["DEVICES"] == "2" and row["LEASE"] == "3s" and row["SEEN"].startswith("for ")
    # --json is the API's answer, alive ones only unless --all.
    api = d.get_json("/v1/participants?state=alive")["participants"]
    assert steady(json.loads(rs_discover("participants", "--json", endpoint=ep).stdout)["participants"]) == steady(api)

    server.kill()
    wait_for(lambda: not table(rs_discover("participants", endpoint=ep).stdout)[1], 10,
             what="the killed server no longer listed as alive")
    r = rs_discover("participants", "--all", endpoint=ep)
    gone = next(x for x in table(r.stdout)[1] if x["NAME"] == "bench-server")
    assert gone["STATE"] == "gone" and gone["DEVICES"] == "0" and gone["SEEN"].endswith(" ago")
    r = rs_discover("participants", endpoint=ep)
    assert r.returncode == 0 and "--all shows those gone too" in r.stderr
    assert rs_discover("participants", "--domain", "300", endpoint=ep).returncode == 2


def test_library_participants(network):
    d, domain, _ = network
    out = subprocess.run([DRIVER, "participants", "unix:" + d.socket], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    seen = [json.loads(x) for x in out.stdout.splitlines()]
    api = {p["guid"]: p for p in d.get_json("/v1/participants")["participants"]}
    assert {p["guid"] for p in seen} == set(api)
    server = next(p for p in seen if p["name"] == "bench-server")
    expected = api[server["guid"]]
    assert server == {"name": "bench-server", "vendor": "fast-dds", "state": "alive", "devices": 2,
                      "lease": expected["lease-seconds"], "addresses": expected["addresses"],
                      "never_announced": False, "guid": expected["guid"]}


def test_python_participants(network):
    d, domain, _ = network
    found = rsdiscovery.participants(endpoint="unix:" + d.socket)
    assert steady([p.raw for p in found]) == steady(d.get_json("/v1/participants?state=alive")["participants"])
    assert [p.name for p in rsdiscovery.participants(domain=domain, state="ALIVE", endpoint="unix:" + d.socket)] \
        == ["bench-server"]
    with pytest.raises(ValueError):
        rsdiscovery.participants(state="sleeping", endpoint="unix:" + d.socket)
    with pytest.raises(ValueError):
        rsdiscovery.participants(domain=300, endpoint="unix:" + d.socket)
    cli = subprocess.run([sys.executable, "-m", "rsdiscovery", "--endpoint", "unix:" + d.socket, "--json",
                          "participants"], capture_output=True, text=True, timeout=30,
                         env=dict(os.environ, PYTHONPATH=os.path.join(SOURCE, "client", "python", "src")))
    assert cli.returncode == 0, cli.stderr
    assert [p["name"] for p in json.loads(cli.stdout)] == ["bench-server"]
