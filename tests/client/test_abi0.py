"""librsdiscovery.so.0 keeps its ABI across DeviceFilter's `host` (issue 25): a program
built against the header as it was before (DeviceFilter without `host`, taken from git
at ABI0_COMMIT) runs on today's shared library, unchanged, against the real daemon; its
filters and watch options arrive as it set them, as they do for the same program built
against today's header. The library exports every symbol the earlier one did."""
import json
import os
import subprocess

import pytest
from client_util import BUILD, DOMAIN_RANGE, SOURCE
from conftest import device_info, wait_for

# The last commit whose header had DeviceFilter without `host`: the layout programs
# built against librsdiscovery0 until then have.
ABI0_COMMIT = "00be6e98e9791e82257cc2f12ee98796823a1cb2"
HEADER = "client/include/rsdiscovery/rsdiscovery.hpp"
LIBDIR = os.path.join(BUILD, "client")
PROGRAM = os.path.join(os.path.dirname(os.path.abspath(__file__)), "abi0_program.cpp")


@pytest.fixture(scope="module")
def programs(tmp_path_factory):
    """{"abi0": built against ABI0_COMMIT's header, "now": against today's}."""
    tmp = tmp_path_factory.mktemp("abi0")
    old = tmp / "old" / "rsdiscovery"
    old.mkdir(parents=True)
    r = subprocess.run(["git", "-C", SOURCE, "show", f"{ABI0_COMMIT}:{HEADER}"], capture_output=True, text=True)
    assert r.returncode == 0, f"commit {ABI0_COMMIT} (the earlier ABI) is not in this clone: {r.stderr}"
    (old / "rsdiscovery.hpp").write_text(r.stdout)
    assert "inline namespace" not in r.stdout  # the layout before
    built = {}
    for name, include in (("abi0", str(tmp / "old")), ("now", os.path.join(SOURCE, "client", "include"))):
        out = str(tmp / f"program-{name}")
        r = subprocess.run(["c++", "-std=c++17", "-O1", "-Wall", "-Werror", "-I", include, PROGRAM, "-o", out,
                            "-L", LIBDIR, "-lrsdiscovery", "-pthread", f"-Wl,-rpath,{LIBDIR}"],
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        built[name] = out
    return built


def exported(symbols_of):
    r = subprocess.run(["nm", "-D", "--defined-only", symbols_of], capture_output=True, text=True, check=True)
    return {line.split()[-1] for line in r.stdout.splitlines()}


def test_a_program_built_against_the_earlier_header_runs_unchanged(programs, daemon, realdds_server, domains):
    one, other = domains.take(*DOMAIN_RANGE), domains.take(*DOMAIN_RANGE)
    d = daemon([one, other])
    realdds_server(one, [device_info(51)])
    realdds_server(other, [device_info(52)])
    wait_for(lambda: len(d.devices()) == 2, 20, what="both cameras")
    mine = f"dds-{one}-realsense.D455_123622270751"
    theirs = f"dds-{other}-realsense.D455_123622270752"
    want = {"list": [mine], "list_devices": [mine], "wait_until": [theirs], "watch": [mine], "view": [mine],
            "subscribe": [theirs]}
    for name, program in programs.items():
        r = subprocess.run([program, "unix:" + d.socket, str(one), "123622270752"], capture_output=True, text=True,
                           timeout=60)
        assert r.returncode == 0, (name, r.stderr)
        got = {line["call"]: line for line in map(json.loads, r.stdout.splitlines())}
        assert {call: line["ids"] for call, line in got.items()} == want, (name, r.stdout)
        assert got["watch"]["told"] == 1, (name, r.stdout)  # on_status, after the filter, arrived


def test_every_symbol_of_the_earlier_library_is_still_exported(programs):
    # The calls taking the filter types under their earlier names, beside the new ones.
    now = exported(os.path.join(LIBDIR, "librsdiscovery.so.0"))
    undefined = subprocess.run(["nm", "-D", "--undefined-only", programs["abi0"]], capture_output=True, text=True,
                               check=True).stdout
    wanted = {line.split()[-1] for line in undefined.splitlines() if "rsdiscovery" in line}
    assert wanted and wanted <= now, sorted(wanted - now)
    assert any("filters2" in s and "DeviceFilter" in s for s in now)
