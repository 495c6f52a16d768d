#!/usr/bin/env python3
"""Cold start of `rs-discover list` against a real daemon holding 100 real realdds devices.

Starts rs-discoveryd on its own domain, socket and port, and realdds servers
(tests/tools/realdds_server.py, 4 participants x 25 devices), waits until the daemon
lists all 100, then times whole `rs-discover` processes (fork, exec, dynamic loading,
one request, table output) and reports min / median / p90 in milliseconds, and each
command's time over /bin/true's, paired: the commands run in turn, in a random order
each turn, so load from elsewhere on the (shared) machine hits all of them alike; the
ratio is the median over blocks of 20 turns of the block's medians.

    bench/client_cold_start.py --build build [--runs 200] [--domain 198] [--compare OTHER_RS_DISCOVER]

--compare adds `list (table)` of another rs-discover binary (a build of main, say) to
the same turns: a before/after measured side by side.
"""
import argparse
import json
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request

from bench_common import block_ratios, spawn_paired

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


FLOOR = "/bin/true (process floor)"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--domain", type=int, default=198)
    ap.add_argument("--devices", type=int, default=100)
    ap.add_argument("--compare", help="another rs-discover binary whose `list` runs in the same turns")
    args = ap.parse_args()
    cli = os.path.join(args.build, "client", "rs-discover")
    daemon_bin = os.path.join(args.build, "daemon", "rs-discoveryd")
    tmp = tempfile.mkdtemp(prefix="rsd-bench-")
    sock = os.path.join(tmp, "api.sock")
    port = free_port()
    procs = []
    try:
        daemon = subprocess.Popen([daemon_bin, "--domain", str(args.domain), "--socket", sock, "--http",
                                   f"127.0.0.1:{port}", "--no-usb"], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL)
        procs.append(daemon)
        per = 25
        for s in range(0, args.devices, per):
            cmd = [sys.executable, os.path.join(ROOT, "tests", "tools", "realdds_server.py"), "--domain",
                   str(args.domain), "--name", f"bench-{s // per}"]
            for n in range(s, min(s + per, args.devices)):
                serial = f"{900000000000 + n}"
                cmd += ["--device", json.dumps({"name": "Intel RealSense D455", "serial": serial,
                                                "product-line": "D400", "product-id": "0B5C",
                                                "fw-version": "5.16.0.1", "topic-root": f"realsense/D455_{serial}"})]
            p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
            procs.append(p)
            p.stdout.readline()
        deadline = time.monotonic() + 120
        count = 0
        while time.monotonic() < deadline:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/healthz", timeout=1) as r:
                    count = json.load(r)["devices"]
            except OSError:
                count = 0
            if count >= args.devices:
                break
            time.sleep(0.1)
        if count < args.devices:
            sys.exit(f"only {count} of {args.devices} devices appeared")
        ep = "unix:" + sock
        print(f"rs-discover cold start, {args.devices} devices, {args.runs} runs each, paired "
              "(ms: min / median / p90; x /bin/true: median [min-max] over blocks)")
        cmds = dict([
            ("list (table)", [cli, "--endpoint", ep, "list"]),
            ("list --json", [cli, "--endpoint", ep, "list", "--json"]),
            ("list over HTTP", [cli, "--endpoint", f"http://127.0.0.1:{port}", "list"]),
            ("health", [cli, "--endpoint", ep, "health"]),
            ("--version (no request)", [cli, "--version"]),
            # The floor of `list`: a bare C process asking the same (cmd_list.cpp's table fields).
            ("bare C client (floor)", [os.path.join(args.build, "bench", "rsd-bench-cold-floor"), sock,
                                       "/v1/devices?fields=" + "%2C".join(
                                           ["name", "serial", "source", "sources", "domain", "usb", "host",
                                            "server.addresses", "first-seen", "recovery", "warnings", "in-use"])]),
            (FLOOR, ["/bin/true"]),
        ] + ([("list (table), --compare", [args.compare, "--endpoint", ep, "list"])] if args.compare else []) + ([("curl --unix-socket /v1/devices", ["curl", "-sf", "--unix-socket", sock,
                                                  "http://localhost/v1/devices"])] if shutil.which("curl") else []))
        samples = spawn_paired(cmds, args.runs)
        for label, v in samples.items():
            ratios = block_ratios(v, samples[FLOOR])
            v = sorted(v)
            print(f"  {label:34s} {v[0]:6.2f} / {statistics.median(v):6.2f} / {v[int(len(v) * 0.9)]:6.2f}"
                  f"   {statistics.median(ratios):4.2f}x [{min(ratios):.2f}-{max(ratios):.2f}]")
    finally:
        for p in reversed(procs):
            p.kill()
            p.wait()
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
