#!/usr/bin/env python3
"""bench/run: every comparison of issue 10, side by side, in one run.

    bench/run [--quick | --smoke] [--build DIR] [--out DIR]

Starts its own rs-discoveryd instances (own DDS domains from the test suite's domain
locks, own Unix sockets and TCP ports, so it runs beside the tests) with real realdds
servers (tests/tools/realdds_server.py), and measures each against its anchor in the
same run:

  http          GET /v1/devices, N devices, 64 and 1 connections, over TCP (wrk) and over the
                Unix socket (bench/rsd-load.c), against nginx serving the same bytes from a
                file (TCP and Unix socket); repetitions interleaved, ratios paired per repetition
  cli_cold      cold `rs-discover list` against /bin/true, a bare C client and curl, every command
                once a turn in a random order
  client_library  in-process rsdiscovery::Client::list() of N devices, against its floor: the
                same request answered 304 on a plain socket, plus copying the list; and a kept
                DeviceView's devices() (no request), against copying the list
  librealsense  pyrealsense2.context({"dds": ...}).query_devices(): the anchor for
                "which cameras are there"
  discovery     realdds broadcast() -> `added` event, against a bare Cyclone reader
  removal       stopping -> `removed`, SIGKILL -> `removed` (lease), with the reader's floor
  scale         1,000 devices from 10 participants over 4 domains: time until listed, RSS
  scale10k      10,000 cameras (raw Cyclone writers, realdds servers among them) from 100
                participants over 4 domains: time until listed, RSS and where it goes (beside a
                daemon with every cap at 1: Cyclone's share), full and filtered lists under 10
                clients, one change to 100 SSE watchers (bench/scale_large.py)
  fanout        100 SSE watchers: change -> last watcher
  share         a USB camera plugged on host A -> listed on host B, sharing on, and unplugged
                (two network namespaces, umockdev; bench/share_latency.py)
  clients       a realdds client making a device -> the daemon's own DDS discovery of it -> the
                camera's `changed` event counting it, and quit -> the event without it
                (bench/client_latency.py)
  describe      Camera Discovery of a 5-stream realdds camera: first request -> description,
                and a cached one, against pyrealdds' own device.wait_until_ready()
  idle          CPU-seconds per minute with N devices, with no client and with the watchers
  open          from "the daemon lists camera X" to a ready device and to its first frame, each
                path in a fresh process (bench/open_paths.py): query_devices(), a devices-changed
                context, rsdiscovery.librealsense.device(), rsdiscovery.realdds.open(); a D555-like
                realdds camera that publishes images; where realdds.open's time goes

Writes OUT/latest.json and OUT/latest.md (OUT: bench/results). --quick does the same in
under two minutes; --smoke is a tiny run (under a minute) that CI uses so the harness does
not rot: its numbers mean nothing. No speed is asserted anywhere: the table says which
targets are met on this machine, this time.
"""
import argparse
import datetime
import hashlib
import http.client
import json
import os
import queue
import re
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "tests"))

import conftest  # noqa: E402  (the suite's daemon, realdds server and domain-lock helpers)

MODES = {
    # devices: in the main daemon (servers x per server); http_secs: per load run;
    # reps: repetitions, interleaved; scale: (devices, participants, domains)
    "full": dict(servers=4, per_server=25, http_reps=5, http_secs=5, rsd_load_tcp=True, cli_runs=400,
                 lib_iters=5000, lib_reps=3, rs_reps=5, lat_reps=15, kill_reps=5, scale=(1000, 10, 4),
                 watchers=100, changes=50, idle_secs=60, sse_connect_s=10, describe_reps=10,
                 open_reps=10),
    "quick": dict(servers=4, per_server=25, http_reps=3, http_secs=1, rsd_load_tcp=False, cli_runs=60,
                  lib_iters=500, lib_reps=2, rs_reps=1, lat_reps=5, kill_reps=2, scale=(1000, 10, 4),
                  watchers=100, changes=16, idle_secs=6, sse_connect_s=4, describe_reps=4,
                  open_reps=3),
    "smoke": dict(servers=2, per_server=5, http_reps=1, http_secs=1, rsd_load_tcp=False, cli_runs=5,
                  lib_iters=50, lib_reps=1, rs_reps=1, lat_reps=1, kill_reps=1, scale=(20, 4, 2),
                  watchers=10, changes=2, idle_secs=1, sse_connect_s=4, describe_reps=1,
                  open_reps=1),
}
SECTIONS = ["http", "cli_cold", "client_library", "librealsense", "discovery", "removal", "scale", "fanout", "describe",
            "idle", "open", "scale10k", "share", "clients"]


import scale_large  # noqa: E402
from bench_common import (  # noqa: E402
    BenchError, log, wait_until, stats, ratio, med_of, Lines, unix_get, rss_kb, cpu_seconds, device_info,
    thread_switches, spawn_paired, block_ratios)


class Bench:
    def __init__(self, args):
        self.args = args
        self.mode = "smoke" if args.smoke else "quick" if args.quick else "full"
        self.p = MODES[self.mode]
        self.build = os.path.abspath(args.build)
        self.tmp = tempfile.mkdtemp(prefix="rsd-bench-")
        os.chmod(self.tmp, 0o755)
        # The binaries are copied at the start: a rebuild of the tree during the run (the
        # machine is shared) must not swap them between one comparison and the next.
        self.binaries = {}
        bindir = os.path.join(self.tmp, "bin")
        os.makedirs(bindir)
        for name, rel in (("rs-discoveryd", ("daemon", "rs-discoveryd")), ("rs-discover", ("client", "rs-discover"))):
            src = os.path.join(self.build, *rel)
            dst = os.path.join(bindir, name)
            shutil.copy2(src, dst)
            with open(dst, "rb") as f:
                self.binaries[name] = {"built": datetime.datetime.fromtimestamp(
                    os.path.getmtime(src), datetime.timezone.utc).isoformat(timespec="seconds"),
                    "sha256": hashlib.sha256(f.read()).hexdigest()[:16]}
        conftest.DAEMON = os.path.join(bindir, "rs-discoveryd")
        self.cli = os.path.join(bindir, "rs-discover")
        self.locks = conftest.DomainLocks()
        self.cleanup = []
        self.results = {}
        self.python = sys.executable

    # ---- processes ---------------------------------------------------------------------
    def start_daemon(self, domains, name, extra=()):
        sock = os.path.join(self.tmp, f"{name}.sock")
        port = conftest.free_port()
        cfg = os.path.join(self.tmp, "empty-config.json")
        with open(cfg, "w") as f:
            f.write("{}")
        args = []
        for d in domains:
            args += ["--domain", str(d)]
        args += ["--config", cfg, "--socket", sock, "--http", f"127.0.0.1:{port}", "--no-usb", "--log-level",
                 "warning"] + list(extra)
        d = conftest.Daemon(args, self.tmp, sock, port)
        self.cleanup.append(d.stop)

        def ready():
            if d.proc.poll() is not None:
                raise BenchError(f"daemon exited with {d.proc.returncode}:\n{d.log()[-2000:]}")
            try:
                status, body = unix_get(sock, "/v1/domains", timeout=1)
            except OSError:
                return False
            return status == 200 and all(x["state"] == "running" for x in json.loads(body)["domains"])
        wait_until(ready, 20, f"daemon {name} ready")
        return d

    def start_servers(self, domain_of, devices_of, name):
        """Starts realdds servers at once (one participant each); returns them once every
        one has broadcast all its devices, with the monotonic time of its last broadcast."""
        procs = []
        for i, (domain, devices) in enumerate(zip(domain_of, devices_of)):
            cmd = [self.python, os.path.join(ROOT, "tests", "tools", "realdds_server.py"), "--domain", str(domain),
                   "--name", f"{name}-{i}"]
            for info in devices:
                cmd += ["--device", json.dumps(info)]
            p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
            procs.append(p)
            self.cleanup.append(lambda p=p: (p.kill(), p.wait()))
        servers = []
        for p in procs:
            s = conftest.RealddsServer.__new__(conftest.RealddsServer)
            s.proc = p
            s.hello = s._reply()
            servers.append(s)
        return servers

    def count(self, d):
        try:
            status, body = unix_get(d.socket, "/healthz", timeout=2)
            return json.loads(body).get("devices", 0) if status == 200 else 0
        except (OSError, ValueError):
            return 0

    def tool(self, name, source, lang):
        """A helper of bench/CMakeLists.txt from the build tree; built there when missing."""
        path = os.path.join(self.build, "bench", name)
        if os.path.exists(path) and os.path.getmtime(path) >= os.path.getmtime(os.path.join(HERE, source)):
            return path  # built (the suite's ctest must not run a build in the tree it tests)
        r = subprocess.run(["cmake", "--build", self.build, "--target", name], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True)
        if r.returncode == 0 and os.path.exists(path):
            return path
        if lang == "c":  # no dependencies: compile it by hand
            path = os.path.join(self.tmp, name)
            subprocess.run(["cc", "-O2", "-o", path, os.path.join(HERE, source), "-lpthread"], check=True)
            return path
        raise BenchError(f"cannot build {name}: {r.stdout[-1500:]}")

    # ---- sections ----------------------------------------------------------------------
    def asked_for(self, name):
        """False for a section --only leaves out (so it is not reported as failed)."""
        only = [x for x in self.args.only.split(",") if x] if getattr(self.args, "only", "") else []
        return not only or name in only or (name == "discovery" and "removal" in only)

    def section(self, name, fn):
        if not self.asked_for(name):
            return
        log(f"{name} ...")
        t0 = time.monotonic()
        try:
            self.results[name] = fn()
        except BaseException as e:  # noqa: BLE001  (pytest.fail's Failed is a BaseException)
            if isinstance(e, KeyboardInterrupt):
                raise
            self.results[name] = {"error": f"{type(e).__name__}: {e}", "trace": traceback.format_exc()[-3000:]}
            log(f"{name} FAILED: {e}")
        self.results[name]["elapsed_s"] = round(time.monotonic() - t0, 2)
        log(f"{name} done in {self.results[name]['elapsed_s']} s")

    def run(self):
        p = self.p
        started = time.time()
        self.load = self.tool("rsd-bench-load", "rsd-load.c", "c")
        n = p["servers"] * p["per_server"]
        try:
            self.d_main = self.locks.take()
            self.d_lat = self.locks.take()
            self.d_scale = [self.locks.take() for _ in range(p["scale"][2])]
            log(f"mode {self.mode}; domains: main {self.d_main}, latency {self.d_lat}, scale {self.d_scale}; "
                f"tmp {self.tmp}")
            self.main = self.start_daemon([self.d_main], "main")
            infos = [device_info(i) for i in range(n)]
            self.servers = self.start_servers([self.d_main] * p["servers"],
                                              [infos[i::p["servers"]] for i in range(p["servers"])], "bench")
            wait_until(lambda: self.count(self.main) >= n, 60, f"{n} devices listed")
            self.devices = n
            self.section("http", self.bench_http)
            self.section("cli_cold", self.bench_cli)
            self.section("client_library", self.bench_client_library)
            self.section("librealsense", self.bench_librealsense)
            self.section("idle", self.bench_idle)
            self.section("fanout", self.bench_fanout)
            self.section("discovery", self.bench_discovery_removal)
            self.section("scale", self.bench_scale)
            self.section("describe", self.bench_describe)
            self.section("open", self.bench_open)
            self.section("scale10k", lambda: scale_large.run(self))
            self.section("share", self.bench_share)
            self.section("clients", self.bench_clients)
        finally:
            for fn in reversed(self.cleanup):
                try:
                    fn()
                except Exception:  # noqa: BLE001
                    pass
            self.locks.release()
        # discovery and removal are measured together; reported as two sections
        disc = self.results.get("discovery", {})
        if "removal" in disc:
            self.results["removal"] = disc.pop("removal")
            self.results["removal"]["elapsed_s"] = 0
        for s in SECTIONS:
            if self.asked_for(s):
                self.results.setdefault(s, {"error": "not run"})
        return {"meta": self.meta(started), "sections": self.results, "table": self.table()}

    def meta(self, started):
        def git(*a):
            r = subprocess.run(["git", "-C", ROOT] + list(a), stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                               text=True)
            return r.stdout.strip()
        return {"mode": self.mode, "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                "commit": git("rev-parse", "--short", "HEAD"),
                "dirty_tree": bool(git("status", "--porcelain", "--untracked-files=no")),
                "build": self.build, "build_type": self._build_type(), "binaries": self.binaries, "nproc": os.cpu_count(),
                "loadavg_end": list(os.getloadavg()), "seconds": round(time.time() - started, 1),
                "devices": self.p["servers"] * self.p["per_server"],
                "note": "shared 2-core machine (other engineers build and test on it): numbers are noisy; "
                        "ratios are paired within this run"}

    def _build_type(self):
        try:
            with open(os.path.join(self.build, "CMakeCache.txt")) as f:
                m = re.search(r"^CMAKE_BUILD_TYPE:\w+=(.*)$", f.read(), re.M)
                return m.group(1) if m else None
        except OSError:
            return None

    # -- http ------------------------------------------------------------------------------
    def start_nginx(self, body, name="nginx"):
        nginx = shutil.which("nginx") or "/usr/sbin/nginx"
        if not os.path.exists(nginx):
            raise BenchError("nginx is not installed (dev.sh installs nginx-light)")
        base = os.path.join(self.tmp, name)
        os.makedirs(os.path.join(base, "www"), exist_ok=True)
        for sub in ("body", "proxy", "fastcgi", "uwsgi", "scgi"):
            os.makedirs(os.path.join(base, sub), exist_ok=True)
        with open(os.path.join(base, "www", "devices.json"), "wb") as f:
            f.write(body)
        port = conftest.free_port()
        sock = os.path.join(base, "nginx.sock")
        user = "user root root;" if os.geteuid() == 0 else ""
        conf = f"""
{user}
daemon off;
worker_processes 2;
pid {base}/nginx.pid;
error_log {base}/error.log warn;
events {{ worker_connections 1024; }}
http {{
  access_log off;
  sendfile on;
  tcp_nodelay on;
  client_body_temp_path {base}/body; proxy_temp_path {base}/proxy; fastcgi_temp_path {base}/fastcgi;
  uwsgi_temp_path {base}/uwsgi; scgi_temp_path {base}/scgi;
  server {{
    listen 127.0.0.1:{port};
    listen unix:{sock};
    root {base}/www;
    location = /v1/devices {{ default_type application/json; try_files /devices.json =404; }}
  }}
}}
"""
        with open(os.path.join(base, "nginx.conf"), "w") as f:
            f.write(conf)
        proc = subprocess.Popen([nginx, "-p", base, "-e", os.path.join(base, "error.log"), "-c",
                                 os.path.join(base, "nginx.conf")], stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE)

        def stop():
            proc.send_signal(signal.SIGQUIT)
            try:
                proc.wait(5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        self.cleanup.append(stop)

        def up():
            if proc.poll() is not None:
                raise BenchError(f"nginx exited: {proc.stderr.read().decode()[-1000:]}")
            try:
                s, b = unix_get(sock, "/v1/devices", timeout=1)
                return s == 200 and b == body
            except OSError:
                return False
        wait_until(up, 10, "nginx serving")
        return port, sock, proc

    def wrk(self, port, conns, secs):
        threads = 2 if conns > 1 else 1
        r = subprocess.run(["wrk", f"-t{threads}", f"-c{conns}", f"-d{max(1, int(round(secs)))}s", "--latency",
                            f"http://127.0.0.1:{port}/v1/devices"], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True, timeout=secs + 30)
        out = r.stdout

        def ms(text):
            m = re.match(r"([\d.]+)(us|ms|s)$", text)
            v = float(m.group(1))
            return v / 1000 if m.group(2) == "us" else v if m.group(2) == "ms" else v * 1000
        rps = re.search(r"Requests/sec:\s+([\d.]+)", out)
        p50 = re.search(r"^\s+50%\s+(\S+)", out, re.M)
        p99 = re.search(r"^\s+99%\s+(\S+)", out, re.M)
        if not (rps and p50 and p99):
            raise BenchError(f"wrk output not understood:\n{out[-1500:]}")
        errors = 0
        for m in re.finditer(r"Non-2xx or 3xx responses: (\d+)", out):
            errors += int(m.group(1))
        m = re.search(r"Socket errors: connect (\d+), read (\d+), write (\d+), timeout (\d+)", out)
        if m:
            errors += sum(int(x) for x in m.groups())
        return {"rps": float(rps.group(1)), "p50_ms": ms(p50.group(1)), "p99_ms": ms(p99.group(1)),
                "errors": errors}

    def rsd_load(self, target, conns, secs):
        threads = 2 if conns > 1 else 1
        r = subprocess.run([self.load, "http"] + target + ["-c", str(conns), "-t", str(threads), "-d", str(secs)],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=secs + 30)
        if not r.stdout.strip():
            raise BenchError(f"rsd-load failed: {r.stderr[-1000:]}")
        return json.loads(r.stdout)

    def bench_http(self):
        p = self.p
        status, body = unix_get(self.main.socket, "/v1/devices")
        assert status == 200
        doc = json.loads(body)
        if len(doc["devices"]) != self.devices:
            raise BenchError(f"{len(doc['devices'])} devices listed, not {self.devices}")
        nport, nsock, _ = self.start_nginx(body)
        # tool, transport -> how to reach the daemon / nginx
        targets = [("wrk", "tcp")] + ([("rsd-load", "tcp")] if p["rsd_load_tcp"] else []) + [("rsd-load", "unix")]
        runs = {}
        for rep in range(p["http_reps"]):
            for conns in (64, 1):
                for tool, transport in targets:
                    for server in ("rs-discoveryd", "nginx"):
                        if tool == "wrk":
                            port = self.main.port if server == "rs-discoveryd" else nport
                            res = self.wrk(port, conns, p["http_secs"])
                        else:
                            if transport == "unix":
                                target = ["--unix", self.main.socket if server == "rs-discoveryd" else nsock]
                            else:
                                port = self.main.port if server == "rs-discoveryd" else nport
                                target = ["--tcp", f"127.0.0.1:{port}"]
                            res = self.rsd_load(target, conns, p["http_secs"])
                        runs.setdefault((conns, tool, transport, server), []).append(res)
        rows = []
        for (conns, tool, transport, server), rs in runs.items():
            if server != "rs-discoveryd":
                continue
            ng = runs[(conns, tool, transport, "nginx")]
            row = {"connections": conns, "tool": tool, "transport": transport}
            for who, res in (("rs_discoveryd", rs), ("nginx", ng)):
                row[who] = {k: stats([x[k] for x in res]) for k in ("rps", "p50_ms", "p99_ms")}
                row[who]["errors"] = sum(x.get("errors", 0) for x in res)
            # paired: each repetition's daemon run against the nginx run right beside it
            row["ratio"] = {
                "rps": stats([ratio(a["rps"], b["rps"]) for a, b in zip(rs, ng)]),
                "p50": stats([ratio(a["p50_ms"], b["p50_ms"]) for a, b in zip(rs, ng)]),
                "p99": stats([ratio(a["p99_ms"], b["p99_ms"]) for a, b in zip(rs, ng)]),
            }
            rows.append(row)
        return {"devices": self.devices, "body_bytes": len(body), "seconds_per_run": p["http_secs"],
                "repetitions": p["http_reps"], "anchor": "nginx (Debian) serving the same bytes from a file",
                "rows": rows}

    # -- cold CLI ---------------------------------------------------------------------------
    def bench_cli(self):
        cli = self.cli
        # The floor of the list: a bare C process asking what `list` asks (cmd_list.cpp's
        # table fields) and printing the body; only what it leaves out is the CLI's own.
        floor = self.tool("rsd-bench-cold-floor", "cold-floor.c", "c")
        fields = ["name", "serial", "source", "sources", "domain", "usb", "host", "server.addresses", "first-seen",
                  "recovery", "warnings", "in-use"]
        cmds = {"/bin/true": ["/bin/true"],
                "rs-discover list (unix)": [cli, "--endpoint", f"unix:{self.main.socket}", "list"],
                "rs-discover list (http)": [cli, "--endpoint", f"http://127.0.0.1:{self.main.port}", "list"],
                "bare C client (floor)": [floor, self.main.socket, f"/v1/devices?fields={'%2C'.join(fields)}"],
                "curl --unix-socket /v1/devices": ["curl", "-sf", "-o", "/dev/null", "--unix-socket",
                                                   self.main.socket, "http://localhost/v1/devices"]}
        # Every command once a turn, in a random order, and the ratios paired per block of
        # turns: the floor is measured beside the CLI all through.
        turns = self.p["cli_runs"]
        samples = spawn_paired(cmds, turns)
        to_true = {name: block_ratios(v, samples["/bin/true"]) for name, v in samples.items()}
        to_floor = block_ratios(samples["rs-discover list (unix)"], samples["bare C client (floor)"])
        return {"unit": "ms", "runs": turns, "blocks": len(to_floor),
                "commands": {name: stats(v) for name, v in samples.items()},
                "ratio_to_true": {k: statistics.median(v) for k, v in to_true.items()},
                "ratio_to_true_per_block": {k: stats(v) for k, v in to_true.items()},
                "list_ratio_to_floor": stats(to_floor),
                "anchor": "/bin/true (the process floor), curl and the bare C client, each whole process timed "
                          "from spawn to reaped, every command once a turn in a random order; ratios: median over "
                          "blocks of 20 turns of the block's medians"}

    # -- client library ---------------------------------------------------------------------
    def bench_client_library(self):
        prog = self.tool("rsd-bench-client-list", "client_list.cpp", "cxx")
        out = {}
        for name, ep in (("unix", f"unix:{self.main.socket}"), ("http", f"http://127.0.0.1:{self.main.port}")):
            reps = []
            for _ in range(self.p["lib_reps"]):
                r = subprocess.run([prog, ep, str(self.p["lib_iters"])], stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, text=True, timeout=300)
                if r.returncode != 0:
                    raise BenchError(f"client list failed: {r.stderr[-1000:]}")
                reps.append(json.loads(r.stdout))
            if reps[0]["devices"] != self.devices:
                raise BenchError(f"the library listed {reps[0]['devices']} devices, not {self.devices}")
            out[name] = {"median_us": stats([x["median_us"] for x in reps]),
                         "p99_us": stats([x["p99_us"] for x in reps]),
                         "copy_median_us": stats([x["copy_median_us"] for x in reps]),
                         "request_304_median_us": stats([x["request_304_median_us"] for x in reps]),
                         # the floor: asking the daemon at all, and copying what is returned
                         "ratio_to_floor": stats([ratio(x["median_us"], x["request_304_median_us"] + x["copy_median_us"])
                                                  for x in reps]),
                         # a kept DeviceView: no request, so copying the list is the whole floor
                         "view_median_us": stats([x["view_median_us"] for x in reps]),
                         "view_p99_us": stats([x["view_p99_us"] for x in reps]),
                         "view_ratio_to_copy": stats([ratio(x["view_median_us"], x["copy_median_us"]) for x in reps]),
                         "per_call_last_rep": reps[-1]}
        return {"devices": self.devices, "iterations": self.p["lib_iters"], "repetitions": self.p["lib_reps"],
                "endpoints": out}

    # -- librealsense anchor ----------------------------------------------------------------
    def bench_librealsense(self):
        code = ("import json, time\n"
                "t0 = time.monotonic()\n"
                "import pyrealsense2 as rs\n"
                "t1 = time.monotonic()\n"
                f"ctx = rs.context({{'dds': {{'enabled': True, 'domain': {self.d_main}}}}})\n"
                "devs = ctx.query_devices()\n"
                "n = len(devs)\n"
                "t2 = time.monotonic()\n"
                "print(json.dumps({'import_s': t1 - t0, 'query_s': t2 - t1, 'count': n}), flush=True)\n")
        reps = []
        for _ in range(self.p["rs_reps"]):
            t0 = time.monotonic()
            r = subprocess.run([self.python, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               timeout=180)
            total = time.monotonic() - t0
            line = [x for x in r.stdout.splitlines() if x.startswith("{")]
            if r.returncode != 0 or not line:
                raise BenchError(f"pyrealsense2 failed ({r.returncode}): {r.stderr[-1500:]}")
            rec = json.loads(line[-1])
            rec["process_s"] = total
            reps.append(rec)
        cli = self.results.get("cli_cold", {}).get("commands", {}).get("rs-discover list (unix)", {}).get("median")
        q = stats([x["query_s"] * 1000 for x in reps])
        return {"what": "pyrealsense2.context({'dds': {'enabled': True, 'domain': D}}).query_devices()",
                "devices_there": self.devices, "devices_found": [x["count"] for x in reps],
                "query_ms": q, "import_ms": stats([x["import_s"] * 1000 for x in reps]),
                "process_ms": stats([x["process_s"] * 1000 for x in reps]),
                "rs_discover_list_ms": cli, "ratio_rs_discover_to_librealsense": ratio(cli, q.get("median"))}

    # -- idle -----------------------------------------------------------------------------
    def idle_cpu(self, pid, secs, wakeups=None):
        c0, w0, t0 = cpu_seconds(pid), thread_switches(pid), time.monotonic()
        time.sleep(secs)  # the measurement window itself, not a wait for a condition
        c1, w1, t1 = cpu_seconds(pid), thread_switches(pid), time.monotonic()
        if wakeups is not None:
            wakeups.update({k: round((w1[k] - w0[k]) / (t1 - t0) * 60, 1) for k in w0})
        return (c1 - c0) / (t1 - t0) * 60

    def bench_idle(self):
        pid = self.main.proc.pid
        wakeups = {}
        cpu = self.idle_cpu(pid, self.p["idle_secs"], wakeups)
        return {"devices": self.devices, "window_s": self.p["idle_secs"],
                "cpu_s_per_min_no_clients": cpu, "wakeups_per_min": wakeups,
                "rss_kb": rss_kb(pid),
                "note": "utime+stime from /proc/PID/stat (clock ticks: 10 ms resolution); "
                        "with watchers: see fanout.idle_cpu_s_per_min_with_watchers"}

    # -- share ------------------------------------------------------------------------------
    def bench_share(self):
        return self._latency_script("share_latency.py")

    # -- clients ----------------------------------------------------------------------------
    def bench_clients(self):
        return self._latency_script("client_latency.py")

    def _latency_script(self, script):
        """Runs a bench/ script that takes --build and --rounds and prints its JSON last."""
        rounds = {"full": 30, "quick": 10, "smoke": 2}[self.mode]
        r = subprocess.run([sys.executable, os.path.join(HERE, script), "--build", self.build,
                            "--rounds", str(rounds)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           timeout=60 + 5 * rounds)
        if r.returncode != 0:
            raise BenchError(f"{script} exited {r.returncode}: {r.stderr[-1500:]}")
        return json.loads(r.stdout.strip().splitlines()[-1])

    # -- fan-out ----------------------------------------------------------------------------
    def bench_fanout(self):
        w = self.p["watchers"]
        sse = Lines([self.load, "sse", "--unix", self.main.socket, "-c", str(w), "--timeout", str(self.p["sse_connect_s"])])
        self.cleanup.append(sse.close)
        hello = sse.wait(lambda x: "connected" in x, 20, "watchers connected")
        connected = hello["connected"]
        res = {"watchers": w, "connected": connected}
        if connected == 0:
            raise BenchError("no watcher connected")
        sse.drain()
        # A change: a device added to a running server, then its `stopping` (realdds
        # broadcasts a device-info once per device server), alternately.
        server = self.servers[0]
        last, first, spread = [], [], []
        info = None
        closed_mid_run = 0
        for k in range(self.p["changes"]):
            if k % 2 == 0:
                info = device_info(k, prefix="5")
                reply = server.command(cmd="add", info=info)
                kind = "added"
            else:
                reply = server.command(cmd="disconnect", **{"topic-root": info["topic-root"]})
                kind = "removed"
            got = {}
            event_id = None
            deadline = time.monotonic() + 10
            while len(got) < connected:
                ev = sse.wait(lambda x: x.get("event") == kind or x.get("closed"),
                              max(0.01, deadline - time.monotonic()),
                              f"change {k} at {connected} watchers ({len(got)} had it)")
                if ev.get("closed"):
                    if ev.get("was_connected"):
                        connected -= 1
                        closed_mid_run += 1
                    continue
                if event_id is None:
                    event_id = ev["id"]
                if ev["id"] == event_id:
                    got[ev["c"]] = ev["t"]
            ts = sorted(got.values())
            last.append((ts[-1] - reply["t"]) * 1000)
            first.append((ts[0] - reply["t"]) * 1000)
            spread.append((ts[-1] - ts[0]) * 1000)
        if k % 2 == 0:
            server.command(cmd="disconnect", **{"topic-root": info["topic-root"]})
            sse.wait(lambda x: x.get("event") == "removed", 10, "the last removal")
        res.update({"changes": self.p["changes"], "unit": "ms", "closed_during_changes": closed_mid_run,
                    "broadcast_to_first_watcher": stats(first), "broadcast_to_last_watcher": stats(last),
                    "first_to_last_watcher": stats(spread),
                    "note": "changes: a device added (origin: the realdds server's reply after broadcast()) or "
                            "stopping (origin: its reply after broadcast_disconnect()), CLOCK_MONOTONIC; "
                            "watchers: bench/rsd-load sse over the Unix socket, stamped on read"})
        res["idle_cpu_s_per_min_with_watchers"] = self.idle_cpu(self.main.proc.pid, self.p["idle_secs"])
        res["rss_kb_with_watchers"] = rss_kb(self.main.proc.pid)
        sse.close()
        return res

    # -- discovery and removal --------------------------------------------------------------
    def bench_discovery_removal(self):
        d = self.start_daemon([self.d_lat], "latency")
        floor = Lines([self.python, os.path.join(HERE, "dds_floor_reader.py"), "--domain", str(self.d_lat)])
        self.cleanup.append(floor.close)
        floor.wait(lambda x: x.get("ready"), 30, "the floor reader")
        sse = Lines([self.load, "sse", "--unix", d.socket, "-c", "1", "--timeout", "10"])
        self.cleanup.append(sse.close)
        if sse.wait(lambda x: "connected" in x, 15, "event stream")["connected"] != 1:
            raise BenchError("the event stream did not connect")
        disc, disc_floor, stop, stop_floor, kill, kill_floor = [], [], [], [], [], []
        over_floor, kill_over, floor_missed = [], [], []

        def floor_sample(match, what):
            """The anchor's sample, or None when it missed one (seen once on a host at load
            14: the daemon had the `stopping`, the floor reader never did): a missed anchor
            sample is counted and reported, it does not void the daemon's measurements."""
            try:
                return floor.wait(lambda x: x.get("kind") == "sample" and match(x), 15, what)
            except BenchError:
                floor_missed.append(what)
                return None

        server = conftest.RealddsServer(self.d_lat, [], name="bench-latency")
        self.cleanup.append(server.kill)
        for run in range(self.p["lat_reps"]):
            info = device_info(run, prefix="8")
            root = info["topic-root"]
            reply = server.command(cmd="add", info=info)
            ev = sse.wait(lambda x: x.get("event") in ("added", "changed", "removed"), 15, "added")
            if ev["event"] != "added":
                raise BenchError(f"expected added, got {ev}")
            disc.append((ev["t"] - reply["t"]) * 1000)
            fl = floor_sample(lambda x: root in x["data"] and "stopping" not in x["data"], "the floor's sample")
            if fl:
                disc_floor.append((fl["t"] - reply["t"]) * 1000)
                over_floor.append(disc[-1] - disc_floor[-1])
            sent = time.monotonic()
            reply = server.command(cmd="disconnect", **{"topic-root": root})
            ev = sse.wait(lambda x: x.get("event") in ("added", "changed", "removed"), 15, "removed")
            if ev["event"] != "removed":
                raise BenchError(f"expected removed, got {ev}")
            stop.append((ev["t"] - sent) * 1000)
            fl = floor_sample(lambda x: root in x["data"] and "stopping" in x["data"], "the floor's stopping sample")
            if fl:
                stop_floor.append((fl["t"] - sent) * 1000)
        server.quit()
        floor.drain()
        for run in range(self.p["kill_reps"]):
            info = device_info(run, prefix="7")
            victim = conftest.RealddsServer(self.d_lat, [info], name=f"bench-victim-{run}")
            self.cleanup.append(victim.kill)
            ev = sse.wait(lambda x: x.get("event") in ("added", "changed", "removed"), 15, "added")
            if ev["event"] != "added":
                raise BenchError(f"expected added, got {ev}")
            floor.wait(lambda x: x.get("kind") == "sample" and info["topic-root"] in x["data"], 15, "floor sample")
            # the floor: the reader's matched writers drop when the lease expires
            floor.drain()
            t = time.monotonic()
            victim.proc.send_signal(signal.SIGKILL)
            ev = sse.wait(lambda x: x.get("event") in ("added", "changed", "removed"), 30, "removed after SIGKILL")
            if ev["event"] != "removed":
                raise BenchError(f"expected removed, got {ev}")
            kill.append((ev["t"] - t) * 1000)
            try:
                fl = floor.wait(lambda x: x.get("kind") == "matched", 30, "the floor's unmatch")
                kill_floor.append((fl["t"] - t) * 1000)
                kill_over.append(kill[-1] - kill_floor[-1])
            except BenchError:
                pass
            victim.proc.wait()
        sse.close()
        floor.close()
        d.stop()
        return {"unit": "ms", "repetitions": self.p["lat_reps"],
                "origin": "the realdds server's reply right after broadcast() (CLOCK_MONOTONIC)",
                "broadcast_to_added": stats(disc), "dds_floor": stats(disc_floor),
                "over_floor": stats(over_floor),  # paired per repetition, where the floor had it
                "floor_missed": floor_missed,
                "floor_what": "bare Cyclone DDS reader (PyPI cyclonedds, Python listener) of realsense/device-info",
                "removal": {"unit": "ms",
                            "stopping_origin": "the harness writing the `disconnect` command to the realdds server "
                                               "(its broadcast_disconnect() returns after delivery)",
                            "stopping_to_removed": stats(stop), "stopping_floor": stats(stop_floor),
                            "sigkill_repetitions": self.p["kill_reps"], "sigkill_to_removed": stats(kill),
                            "sigkill_floor_unmatched": stats(kill_floor),
                            "sigkill_over_floor": stats(kill_over),
                            "lease_note": "realdds servers' participant lease: the floor reader's unmatch is when "
                                          "Cyclone itself gives the writer up"}}

    # -- scale ------------------------------------------------------------------------------
    def bench_scale(self):
        total, participants, ndomains = self.p["scale"]
        d = self.start_daemon(self.d_scale, "scale")
        rss0 = rss_kb(d.proc.pid)
        per = total // participants
        domain_of = [self.d_scale[i % ndomains] for i in range(participants)]
        devices_of = [[device_info(i * per + k, prefix="6") for k in range(per)] for i in range(participants)]
        t_launch = time.monotonic()
        servers = self.start_servers(domain_of, devices_of, "bench-scale")
        t_announced = max(s.hello["t"] for s in servers)
        t_listed = wait_until(lambda: self.count(d) >= total and time.monotonic(), 120, f"{total} devices listed",
                              interval=0.01)
        rss1 = rss_kb(d.proc.pid)
        status, body = unix_get(d.socket, "/v1/devices")
        doc = json.loads(body)
        res = {"devices": total, "participants": participants, "domains": ndomains,
               "listed_after_last_announced_s": t_listed - t_announced,
               "listed_after_launch_s": t_listed - t_launch,
               "servers_ready_after_launch_s": t_announced - t_launch,
               "rss_kb_empty": rss0, "rss_kb": rss1, "bytes_per_device_rss": (rss1 - rss0) * 1024 / total,
               "list_bytes": len(body), "list_bytes_per_device": len(body) / max(1, len(doc["devices"])),
               "cpu_s_until_listed": cpu_seconds(d.proc.pid)}
        for s in servers:
            s.kill()
        d.stop()
        return res

    # -- Camera Discovery ----------------------------------------------------------------------
    # Five streams, as a D455 serves them (color, depth, two IR, motion), several
    # profiles and options each: what the daemon must collect in order.
    DESCRIBE_SPEC = {
        "streams": [
            {"kind": "color", "name": "Color", "sensor": "RGB Camera",
             "profiles": [[30, "rgb", 1280, 720], [30, "yuyv", 640, 480], [15, "rgb", 1920, 1080]], "default": 1,
             "options": [["Backlight Compensation", 0, 0, 1, 1, 0, "desc"], ["Brightness", 0, -64, 64, 1, 0, "desc"]]},
            {"kind": "depth", "name": "Depth", "sensor": "Stereo Module",
             "profiles": [[30, "z16", 848, 480], [90, "z16", 424, 240]], "default": 0,
             "options": [["Exposure", 8500, 1, 165000, 1, 8500, "desc"]]},
            {"kind": "ir", "name": "Infrared 1", "sensor": "Stereo Module", "profiles": [[30, "y8", 848, 480]],
             "default": 0, "options": []},
            {"kind": "ir", "name": "Infrared 2", "sensor": "Stereo Module", "profiles": [[30, "y8", 848, 480]],
             "default": 0, "options": []},
            {"kind": "motion", "name": "Motion", "sensor": "Motion Module", "profiles": [[200], [400]], "default": 0,
             "options": []},
        ],
        "device-options": [["Laser Power", 150, 0, 360, 30, 150, "desc"]],
        "extrinsics": [["Depth", "Color", [1, 0, 0, 0, 1, 0, 0, 0, 1], [0.015, 0.0, 0.0]]],
    }

    def bench_describe(self):
        domain = self.locks.take()
        d = self.start_daemon([domain], "describe")
        server = conftest.RealddsServer(domain, [], name="bench-describe")
        self.cleanup.append(server.kill)
        anchor = Lines([self.python, os.path.join(HERE, "realdds_describe_anchor.py"), "--domain", str(domain)])
        self.cleanup.append(lambda: (anchor.proc.kill(), anchor.proc.wait()))
        anchor.wait(lambda x: x.get("ready"), 30, "the pyrealdds anchor")
        first, cached, ref, streams = [], [], [], None
        for run in range(self.p["describe_reps"]):
            # A camera of its own each round: the first request is never a cached answer.
            info = device_info(run, prefix="5")
            server.command(cmd="add", info=info, spec=self.DESCRIBE_SPEC)
            cam_id = "dds-%d-%s" % (domain, info["topic-root"].replace("/", "."))
            wait_until(lambda: unix_get(d.socket, f"/v1/devices/{cam_id}")[0] == 200, 15, "the camera listed")
            t0 = time.monotonic()
            status, body = unix_get(d.socket, f"/v1/devices/{cam_id}/description", timeout=40)
            first.append((time.monotonic() - t0) * 1000)
            if status != 200:
                raise BenchError(f"description: {status} {body[:300]!r}")
            streams = len(json.loads(body)["streams"])
            t0 = time.monotonic()
            unix_get(d.socket, f"/v1/devices/{cam_id}/description")
            cached.append((time.monotonic() - t0) * 1000)
            # The anchor: librealsense's realdds client getting the same set from the same server.
            anchor.proc.stdin.write(json.dumps(info) + "\n")
            anchor.proc.stdin.flush()
            got = anchor.wait(lambda x: x.get("topic-root") == info["topic-root"], 40, "the anchor's device ready")
            if "error" in got:
                raise BenchError(f"anchor: {got['error']}")
            ref.append(got["ms"])
        d.stop()
        return {"streams": streams, "first_request_ms": stats(first), "cached_request_ms": stats(cached),
                "pyrealdds_wait_until_ready_ms": stats(ref),
                "ratio_first_to_pyrealdds": ratio(stats(first)["median"], stats(ref)["median"])}

    # -- open: from the daemon's list to a ready camera and its first frame (issue 22) ----------
    OPEN_PATHS = ["query-devices", "devices-changed", "librealsense", "realdds"]

    def bench_open(self):
        domain = self.locks.take()
        d = self.start_daemon([domain], "open")
        info = {"name": "Intel RealSense D555", "serial": "555000777", "product-line": "D500", "product-id": "0B56",
                "fw-version": "7.56.19829.840", "topic-root": "realsense/D555_555000777"}
        server = conftest.RealddsServer(domain, [], name="bench-open-server")
        self.cleanup.append(server.kill)
        server.command(cmd="add", info=info, spec="d555")  # Depth, Infrared 1, Color; publishes images
        cam_id = "dds-%d-%s" % (domain, info["topic-root"].replace("/", "."))
        wait_until(lambda: unix_get(d.socket, f"/v1/devices/{cam_id}")[0] == 200, 20, "the camera listed")
        env = dict(os.environ, RS_DISCOVERY_ENDPOINT="unix:" + d.socket)
        runs = {p: [] for p in self.OPEN_PATHS}
        abnormal = []
        for rep in range(self.p["open_reps"]):
            # Interleaved, the order turned each repetition: no path always follows another.
            order = self.OPEN_PATHS[rep % 4:] + self.OPEN_PATHS[:rep % 4]
            for path in order:
                cmd = [self.python, os.path.join(HERE, "open_paths.py"), path, "--domain", str(domain), "--serial",
                       info["serial"], "--topic-root", info["topic-root"], "--frame"]
                r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=90, env=env)
                lines = [x for x in r.stdout.splitlines() if x.startswith("{")]
                rec = json.loads(lines[-1]) if lines else {}
                if "ready_s" not in rec:
                    raise BenchError(f"{path}: exit {r.returncode}, {rec.get('error', '')} {r.stderr[-1500:]}")
                if r.returncode != 0:  # after its line: a crash on the way out, noted
                    abnormal.append({"path": path, "exit": r.returncode})
                runs[path].append(rec)
        d.stop()
        out = {"camera": "D555-like realdds server: Depth z16, Infrared 1 y8, Color rgb, 640x480 at 30 fps",
               "repetitions": self.p["open_reps"], "abnormal_exits": abnormal, "paths": {}}
        for path, recs in runs.items():
            ready = [x["ready_s"] * 1000 for x in recs]
            frame = [x["frame_s"] * 1000 for x in recs if "frame_s" in x]
            own = [(x["frame_s"] - x["ready_s"]) * 1000 for x in recs if "frame_s" in x]
            out["paths"][path] = {"ready_ms": stats(ready), "first_frame_ms": stats(frame),
                                  "frame_own_ms": stats(own), "runs": recs}
        q = out["paths"]["query-devices"]
        for path in self.OPEN_PATHS[1:]:
            e = out["paths"][path]
            e["ratio_ready_to_query_devices"] = ratio(med_of(e["ready_ms"]), med_of(q["ready_ms"]))
            e["ratio_frame_to_query_devices"] = ratio(med_of(e["first_frame_ms"]), med_of(q["first_frame_ms"]))
        # Where realdds.open's time goes: its steps (rsdiscovery.realdds.last_open), each a
        # difference of two marks, medians over the repetitions.
        steps = {"participant": ("resolved", "participant"), "server heard": ("participant", "heard"),
                 "endpoints matched": ("heard", "matched"), "device made": ("matched", "device"),
                 "initialization set": ("device", "ready"), "daemon asked": (None, "resolved")}
        rd = runs["realdds"]
        out["realdds_steps_ms"] = {
            name: stats([(x["marks"][b] - (x["marks"][a] if a else 0)) * 1000 for x in rd
                         if x.get("marks") and b in x["marks"] and (a is None or a in x["marks"])])
            for name, (a, b) in steps.items()}
        out["realdds_prodded"] = sum(1 for x in rd if x.get("prods"))
        return out

    # ---- the table --------------------------------------------------------------------------
    def table(self):
        R = self.results
        rows = []

        def f(v, nd=1):
            return "–" if v is None else f"{v:,.{nd}f}"

        def med(s, key="median"):
            return (s or {}).get(key)

        def spread(s, nd=1):
            if not s or not s.get("n"):
                return ""
            return f" [{f(s['min'], nd)}–{f(s['max'], nd)}]" if s["n"] > 1 else ""

        def verdict(ok):
            return "–" if ok is None else ("met" if ok else "**missed**")

        h = R.get("http", {})
        for row in h.get("rows", []):
            rsd, ng, ra = row["rs_discoveryd"], row["nginx"], row["ratio"]
            label = (f"`GET /v1/devices`, {h.get('devices')} devices ({h.get('body_bytes', 0) // 1024} KB), "
                     f"{row['connections']} conn, {row['transport']} ({row['tool']})")
            ok = None
            if row["connections"] == 64 and med(ra["rps"]) is not None:
                # Issue 24's targets (raised from 0.8x and 2x): nginx at its best, matched.
                ok = med(ra["rps"]) >= 1.0 and med(ra["p99"]) <= 1.0
            rows.append({"comparison": label,
                         "rs_discoveryd": f"{f(med(rsd['rps']), 0)} req/s{spread(rsd['rps'], 0)}, "
                                          f"p50 {f(med(rsd['p50_ms']), 2)} ms, p99 {f(med(rsd['p99_ms']), 2)} ms",
                         "anchor": f"nginx {f(med(ng['rps']), 0)} req/s{spread(ng['rps'], 0)}, "
                                   f"p50 {f(med(ng['p50_ms']), 2)} ms, p99 {f(med(ng['p99_ms']), 2)} ms",
                         "ratio": f"{f(med(ra['rps']), 2)}× req/s, {f(med(ra['p99']), 1)}× p99",
                         "target": ("≥ 1.0× req/s, ≤ 1.0× p99: " + verdict(ok)) if row["connections"] == 64 else ""})
        c = R.get("cli_cold", {})
        if "commands" in c:
            fl = c["commands"].get("bare C client (floor)")
            for name in ("rs-discover list (unix)", "rs-discover list (http)", "curl --unix-socket /v1/devices"):
                s = c["commands"][name]
                r = c["ratio_to_true"][name]
                ratio_text = (f"{f(r, 1)}×{spread(c['ratio_to_true_per_block'][name], 1)} `/bin/true` "
                              f"({f(c['commands']['/bin/true']['median'], 2)} ms)")
                ok = None
                if name == "rs-discover list (unix)" and fl:  # issue 33: the floor asks and reads too
                    rf = c["list_ratio_to_floor"]
                    ok = rf["median"] <= 1.5
                    ratio_text = (f"{f(rf['median'], 2)}×{spread(rf, 2)} the bare C client "
                                  f"({f(fl['median'], 2)} ms); " + ratio_text)
                rows.append({"comparison": f"cold `{name}`",
                             "rs_discoveryd" if name.startswith("rs") else "anchor":
                                 f"{f(s['median'], 2)} ms median [p10 {f(s['p10'], 2)}, p90 {f(s['p90'], 2)}]",
                             "anchor" if name.startswith("rs") else "rs_discoveryd": "",
                             "ratio": ratio_text,
                             "target": ("≤ 1.5× the bare C client: " + verdict(ok)) if ok is not None else ""})
        cl = R.get("client_library", {})
        for name, e in cl.get("endpoints", {}).items():
            m = med(e["median_us"])
            ok = m <= 100 if name == "unix" else None
            rows.append({"comparison": f"in-process client-library list, {cl['devices']} devices, {name}",
                         "rs_discoveryd": f"{f(m, 0)} µs median{spread(e['median_us'], 0)}, "
                                          f"p99 {f(med(e['p99_us']), 0)} µs",
                         "anchor": f"the same request answered 304 on a plain socket "
                                   f"{f(med(e['request_304_median_us']), 0)} µs + copying the list "
                                   f"{f(med(e['copy_median_us']), 0)} µs",
                         "ratio": f"{f(med(e['ratio_to_floor']), 2)}× the two",
                         "target": ("≤ 100 µs median: " + verdict(ok) + " (a request each call)")
                                   if ok is not None else ""})
            if "view_median_us" not in e:
                continue
            v = med(e["view_median_us"])
            ok = v <= 100 if name == "unix" else None
            rows.append({"comparison": f"in-process client-library list, {cl['devices']} devices, a kept "
                                       f"DeviceView ({name})",
                         "rs_discoveryd": f"{f(v, 0)} µs median{spread(e['view_median_us'], 0)}, "
                                          f"p99 {f(med(e['view_p99_us']), 0)} µs",
                         "anchor": f"copying the list {f(med(e['copy_median_us']), 0)} µs",
                         "ratio": f"{f(med(e['view_ratio_to_copy']), 2)}× the copy",
                         "target": ("≤ 100 µs median: " + verdict(ok)) if ok is not None else ""})
        lr = R.get("librealsense", {})
        if "query_ms" in lr:
            rows.append({"comparison": "which cameras are there: librealsense `query_devices()` (DDS) vs "
                                       "cold `rs-discover list`",
                         "rs_discoveryd": f"{f(lr['rs_discover_list_ms'], 2)} ms",
                         "anchor": f"pyrealsense2 {f(med(lr['query_ms']), 0)} ms{spread(lr['query_ms'], 0)}, "
                                   f"found {lr['devices_found']} of {lr['devices_there']}",
                         "ratio": f"{f(lr['ratio_rs_discover_to_librealsense'], 4)}×", "target": ""})
        di = R.get("discovery", {})
        if "broadcast_to_added" in di:
            over = med(di["over_floor"])
            rows.append({"comparison": "discovery: realdds `broadcast()` → `added` event",
                         "rs_discoveryd": f"{f(med(di['broadcast_to_added']), 2)} ms{spread(di['broadcast_to_added'], 2)}",
                         "anchor": f"bare Cyclone reader {f(med(di['dds_floor']), 2)} ms{spread(di['dds_floor'], 2)}"
                                   + (f"; it missed {len(di['floor_missed'])} sample(s)" if di.get("floor_missed") else ""),
                         "ratio": f"+{f(over, 2)} ms over the floor",
                         "target": "≤ floor + 2 ms: " + verdict(over is not None and over <= 2.0)})
        rm = R.get("removal", {})
        if "stopping_to_removed" in rm:
            s = med(rm["stopping_to_removed"])
            rows.append({"comparison": "removal: `stopping` → `removed`",
                         "rs_discoveryd": f"{f(s, 2)} ms{spread(rm['stopping_to_removed'], 2)}",
                         "anchor": f"bare reader gets `stopping` {f(med(rm['stopping_floor']), 2)} ms",
                         "ratio": "", "target": "≤ 10 ms: " + verdict(s is not None and s <= 10)})
            k, kf = med(rm["sigkill_to_removed"]), med(rm["sigkill_floor_unmatched"])
            ok = None if k is None or kf is None else k <= kf + 500
            rows.append({"comparison": "removal: SIGKILL of the server → `removed`",
                         "rs_discoveryd": f"{f(k, 0)} ms{spread(rm['sigkill_to_removed'], 0)}",
                         "anchor": f"bare reader's unmatch (the lease) {f(kf, 0)} ms",
                         "ratio": f"+{f(med(rm['sigkill_over_floor']), 0)} ms",
                         "target": "≤ lease + 0.5 s: " + verdict(ok)})
        rows += scale_large.rows(R.get("scale10k", {}), f)
        sc = R.get("scale", {})
        if "listed_after_last_announced_s" in sc:
            t = sc["listed_after_last_announced_s"]
            rss = sc["rss_kb"] / 1024
            rows.append({"comparison": f"scale: {sc['devices']} devices, {sc['participants']} participants, "
                                       f"{sc['domains']} domains",
                         "rs_discoveryd": f"all listed {f(t, 2)} s after the last was announced "
                                          f"({f(sc['listed_after_launch_s'], 1)} s after launch); RSS {f(rss, 1)} MB; "
                                          f"{f(sc['bytes_per_device_rss'], 0)} B/device (RSS), "
                                          f"{f(sc['list_bytes_per_device'], 0)} B/device (JSON)",
                         "anchor": "", "ratio": "",
                         "target": f"≤ 5 s, RSS ≤ 64 MB: {verdict(t <= 5 and rss <= 64)}"})
        ds = R.get("describe", {})
        if "first_request_ms" in ds:
            rows.append({"comparison": f"Camera Discovery: {ds['streams']}-stream camera, GET .../description",
                         "rs_discoveryd": f"first request {f(med(ds['first_request_ms']), 1)} ms"
                                          f"{spread(ds['first_request_ms'], 1)}, cached "
                                          f"{f(med(ds['cached_request_ms']), 2)} ms",
                         "anchor": f"pyrealdds device.wait_until_ready() "
                                   f"{f(med(ds['pyrealdds_wait_until_ready_ms']), 1)} ms"
                                   f"{spread(ds['pyrealdds_wait_until_ready_ms'], 1)}",
                         "ratio": "–" if ds['ratio_first_to_pyrealdds'] is None
                                  else f"{ds['ratio_first_to_pyrealdds']:.3g}×",
                         "target": "≤ 30 s (the use case's limit): " + verdict(med(ds['first_request_ms']) <= 30000)})
        op = R.get("open", {})
        if "paths" in op:
            P = op["paths"]
            q = P["query-devices"]
            qr, qf = med(q["ready_ms"]), med(q["first_frame_ms"])
            names = {"realdds": "`rsdiscovery.realdds.open()`", "librealsense": "`rsdiscovery.librealsense.device()`",
                     "devices-changed": "a context with `query-devices-max: 0` and a devices-changed callback"}
            rows.append({"comparison": "open a camera the daemon lists, fresh process: librealsense `query_devices()` "
                                       "(DDS), the anchor",
                         "rs_discoveryd": "", "anchor": f"ready {f(qr, 0)} ms{spread(q['ready_ms'], 0)}; first frame "
                                                        f"{f(qf, 0)} ms{spread(q['first_frame_ms'], 0)}",
                         "ratio": "", "target": ""})
            for path in ("realdds", "librealsense", "devices-changed"):
                e = P[path]
                r = med(e["ready_ms"])
                rr = e["ratio_ready_to_query_devices"]
                ok = target = None
                if path == "realdds":
                    ok = None if r is None or rr is None else r <= 50 and rr <= 0.02
                    target = "≤ 50 ms and ≤ 0.02× `query_devices()`: "
                elif path == "librealsense":
                    ok = None if rr is None else rr <= 0.2
                    target = "≤ 0.2× `query_devices()`: "
                rows.append({"comparison": f"open a camera, fresh process: {names[path]} → ready device",
                             "rs_discoveryd": f"{f(r, 1)} ms{spread(e['ready_ms'], 1)}",
                             "anchor": f"`query_devices()` {f(qr, 0)} ms",
                             "ratio": "–" if rr is None else f"{rr:.3g}×",
                             "target": (target + verdict(ok)) if target else ""})
            for path in ("realdds", "librealsense", "devices-changed"):
                e = P[path]
                fr, own = med(e["first_frame_ms"]), med(e["frame_own_ms"])
                factor = {"realdds": 0.1, "librealsense": 0.2}.get(path)
                ok = None if factor is None or None in (fr, own, qr) else fr <= factor * qr + own
                rows.append({"comparison": f"open a camera, fresh process: {names[path]} → first frame "
                                           f"({'Depth, first_frame()' if path == 'realdds' else 'pipeline, depth'})",
                             "rs_discoveryd": f"{f(fr, 1)} ms{spread(e['first_frame_ms'], 1)} (the frame's own "
                                              f"{f(own, 1)} ms after ready)",
                             "anchor": f"`query_devices()` + pipeline {f(qf, 0)} ms",
                             "ratio": "–" if e["ratio_frame_to_query_devices"] is None
                                      else f"{e['ratio_frame_to_query_devices']:.3g}×",
                             "target": (f"≤ {factor}× `query_devices()` + the frame's own time: " + verdict(ok))
                                       if factor else ""})
            st = op.get("realdds_steps_ms", {})
            parts = ", ".join(f"{k} {f(med(v), 1)}" + (f" (max {f(v.get('max'), 0)})" if v.get("n", 0) > 1 else "")
                              for k, v in st.items() if v.get("n"))
            rows.append({"comparison": "where `rsdiscovery.realdds.open()`'s time goes (medians, ms)",
                         "rs_discoveryd": parts + f"; the server prodded in {op.get('realdds_prodded', 0)} of "
                                                  f"{op.get('repetitions')}",
                         "anchor": "", "ratio": "", "target": ""})
        fo = R.get("fanout", {})
        if "broadcast_to_last_watcher" in fo:
            last, spr = fo["broadcast_to_last_watcher"], fo["first_to_last_watcher"]
            p99 = spr.get("p99", spr.get("max"))
            rows.append({"comparison": f"fan-out: {fo['connected']} of {fo['watchers']} SSE watchers connected, "
                                       "change → last watcher",
                         "rs_discoveryd": f"broadcast → last watcher {f(med(last), 2)} ms median, "
                                          f"max {f(last.get('max'), 2)} ms",
                         "anchor": f"first watcher {f(med(fo['broadcast_to_first_watcher']), 2)} ms; first → last "
                                   f"{f(med(spr), 2)} ms median, p99 {f(p99, 2)} ms (n={spr.get('n')})",
                         "ratio": "",
                         "target": "last watcher ≤ 20 ms p99 after the first: " + verdict(
                             None if p99 is None else p99 <= 20 and fo["connected"] == fo["watchers"])})
        sh = R.get("share", {})
        if "a_to_b" in sh:
            rows.append({"comparison": f"share: USB plug on host A → listed on host B ({sh['rounds']} rounds)",
                         "rs_discoveryd": f"A's `added` → B's `added` {f(med(sh['a_to_b']), 2)} ms"
                                          f"{spread(sh['a_to_b'], 2)}; unplug: A's `removed` → B's "
                                          f"{f(med(sh['a_to_b_removed']), 2)} ms{spread(sh['a_to_b_removed'], 2)}",
                         "anchor": f"plug → A's own `added` {f(med(sh['plug_to_a']), 2)} ms; unplug → A's "
                                   f"`removed` {f(med(sh['unplug_to_a']), 2)} ms",
                         "ratio": "",
                         "target": "≤ 5 ms plus DDS delivery: " + verdict(sh["a_to_b"]["max"] <= 5)})
        cl = R.get("clients", {})
        if "daemon_dds_to_listed" in cl:
            own = cl["daemon_dds_to_listed"]
            worst = own.get("p99", own.get("max"))
            rows.append({"comparison": f"clients: a realdds client's first endpoint → its camera's `changed` "
                                       f"({cl['rounds']} clients)",
                         "rs_discoveryd": f"daemon's DDS discovery → `changed` {f(med(own), 2)} ms{spread(own, 2)}; "
                                          f"device made → `changed` {f(med(cl['device_to_listed']), 1)} ms"
                                          f"{spread(cl['device_to_listed'], 1)}; quit → `changed` "
                                          f"{f(med(cl['quit_to_unlisted']), 1)} ms",
                         "anchor": f"device made → the daemon's DDS discovery "
                                   f"{f(med(cl['device_to_daemon_dds']), 1)} ms{spread(cl['device_to_daemon_dds'], 1)}; "
                                   f"→ another stack's (observer) {f(med(cl['device_to_observer']), 1)} ms",
                         "ratio": "",
                         "target": "≤ 100 ms beyond DDS discovery: " + verdict(worst is not None and worst <= 100)})
        idle = R.get("idle", {})
        if "cpu_s_per_min_no_clients" in idle:
            v = idle["cpu_s_per_min_no_clients"]
            vw = fo.get("idle_cpu_s_per_min_with_watchers")
            wk = idle.get("wakeups_per_min", {})
            rows.append({"comparison": f"idle CPU, {idle['devices']} devices ({idle['window_s']} s window)",
                         "rs_discoveryd": f"{f(v, 3)} CPU-s/min, no clients; {f(vw, 3)} CPU-s/min with "
                                          f"{fo.get('connected', '–')} SSE watchers; RSS {f(idle['rss_kb'] / 1024, 1)} MB; "
                                          f"wake-ups/min, no clients: main loop {f(wk.get('main'), 1)}, "
                                          f"other daemon threads {f(wk.get('other'), 1)} "
                                          f"(Cyclone's own {f(wk.get('cyclone'), 1)})",
                         "anchor": "", "ratio": "",
                         "target": "≤ 0.3 CPU-s/min: " + verdict(v <= 0.3 and (vw is None or vw <= 0.3))})
        for s in SECTIONS:
            if "error" in R.get(s, {}):
                rows.append({"comparison": f"{s}", "rs_discoveryd": "**failed**: " + R[s]["error"][:200],
                             "anchor": "", "ratio": "", "target": ""})
        return rows


def markdown(result):
    m = result["meta"]
    out = [f"# bench/run {'--' + m['mode'] if m['mode'] != 'full' else ''}".rstrip(),
           "",
           f"{m['date']}, commit {m['commit']}{' (work tree with uncommitted changes)' if m['dirty_tree'] else ''}, "
           f"{m['build_type']} build, {m['nproc']} cores, load average at the end {m['loadavg_end'][0]:.2f}, "
           f"{m['seconds']} s. {m['note']}.",
           "Medians over repetitions, [min–max] where there were several; ratios paired per repetition.",
           "",
           "| comparison | rs-discoveryd | anchor | ratio | target |",
           "| --- | --- | --- | --- | --- |"]
    for r in result["table"]:
        out.append("| " + " | ".join(str(r.get(k, "")).replace("|", "\\|") for k in
                                     ("comparison", "rs_discoveryd", "anchor", "ratio", "target")) + " |")
    return "\n".join(out) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="the same comparisons in under two minutes")
    g.add_argument("--smoke", action="store_true", help="a tiny run for CI: the harness works, numbers mean nothing")
    ap.add_argument("--build", default=os.environ.get("RSD_BUILD_DIR") or os.path.join(ROOT, "build"))
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    ap.add_argument("--only", default="", help="comma-separated sections to run (default: all): " + ", ".join(SECTIONS))
    args = ap.parse_args()
    bench = Bench(args)
    try:
        result = bench.run()
    finally:
        shutil.rmtree(bench.tmp, ignore_errors=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "latest.json"), "w") as f:
        json.dump(result, f, indent=1)
        f.write("\n")
    md = markdown(result)
    with open(os.path.join(args.out, "latest.md"), "w") as f:
        f.write(md)
    print(md)
    failed = [s for s in SECTIONS if "error" in result["sections"].get(s, {})]
    if failed:
        print(f"sections that failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
