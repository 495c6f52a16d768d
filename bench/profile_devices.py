#!/usr/bin/env python3
"""Where `GET /v1/devices` spends its time: the daemon with 100 real realdds devices,
profiled under load with valgrind's callgrind (instruction counts: repeatable on a shared
machine) or `perf record` where the machine counts cycles (`perf stat -e instructions true`).

    .venv/bin/python bench/profile_devices.py [--build build] [--out bench/results/profile-devices.txt]
                                             [--seconds 20] [--connections 8] [--tool callgrind|perf]

Only the load is profiled: callgrind instruments from `callgrind_control -i on` (once all
devices are listed) to `-i off` (when wrk ends). The file gets the top entries, exclusive
and inclusive, and instructions per request.
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import harness  # noqa: E402
from harness import conftest  # noqa: E402


def collapse(text, name, short):
    """`name<...>` (balanced) -> `short`."""
    out, i = [], 0
    while True:
        j = text.find(name + "<", i)
        if j < 0:
            return "".join(out) + text[i:]
        out.append(text[i:j] + short)
        k, depth = j + len(name), 0
        while k < len(text):
            depth += {"<": 1, ">": -1}.get(text[k], 0)
            k += 1
            if depth == 0:
                break
        i = k


def shorten(line):
    """Readable C++ names: json, std::string, no allocator noise."""
    line = collapse(line, "std::__cxx11::basic_string", "std::string")
    line = collapse(line, "nlohmann::json_abi_v3_11_2::basic_json", "json")
    line = collapse(line, "std::allocator", "A")
    line = collapse(line, "std::char_traits", "T")
    line = line.replace("nlohmann::json_abi_v3_11_2::", "nlohmann::")
    line = line.replace("/usr/include/c++/12/bits/", "").replace("/usr/include/", "")
    return line


def perf_works():
    r = subprocess.run(["perf", "stat", "-e", "instructions", "true"], stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True) if shutil.which("perf") else None
    return bool(r and r.returncode == 0 and "not supported" not in r.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(harness.ROOT, "build"))
    ap.add_argument("--out", default=os.path.join(HERE, "results", "profile-devices.txt"))
    ap.add_argument("--seconds", type=int, default=20)
    ap.add_argument("--connections", type=int, default=8)
    ap.add_argument("--devices", type=int, default=100)
    ap.add_argument("--tool", choices=["auto", "callgrind", "perf"], default="auto")
    args = ap.parse_args()
    tool = args.tool if args.tool != "auto" else ("perf" if perf_works() else "callgrind")

    class A:
        smoke = quick = False
        build = args.build
        out = None
    b = harness.Bench(A())
    daemon_bin = conftest.DAEMON
    cg_out = os.path.join(b.tmp, "callgrind.out")  # callgrind_control -d writes callgrind.out.1
    try:
        dom = b.locks.take()
        sock = os.path.join(b.tmp, "api.sock")
        port = conftest.free_port()
        cfg = os.path.join(b.tmp, "empty.json")
        with open(cfg, "w") as f:
            f.write("{}")
        prefix = (["valgrind", "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={cg_out}"]
                  if tool == "callgrind" else [])
        d = conftest.Daemon(["--domain", str(dom), "--config", cfg, "--socket", sock, "--http", f"127.0.0.1:{port}",
                             "--no-usb", "--log-level", "warning"], b.tmp, sock, port, prefix=prefix)
        b.cleanup.append(d.stop)
        harness.wait_until(lambda: b.count(d) >= 0 and d.healthy(), 120, "the daemon up", interval=0.2)
        per = 25
        infos = [harness.device_info(i) for i in range(args.devices)]
        nserv = (args.devices + per - 1) // per
        b.start_servers([dom] * nserv, [infos[i::nserv] for i in range(nserv)], "profile")
        harness.wait_until(lambda: b.count(d) >= args.devices, 180, f"{args.devices} devices listed", interval=0.2)
        status, body = harness.unix_get(sock, "/v1/devices")
        perf_data = os.path.join(b.tmp, "perf.data")
        if tool == "callgrind":
            subprocess.run(["callgrind_control", "-i", "on", str(d.proc.pid)], check=True, stdout=subprocess.DEVNULL)
            rec = None
        else:
            rec = subprocess.Popen(["perf", "record", "-g", "-o", perf_data, "-p", str(d.proc.pid)],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t0 = time.monotonic()
        w = subprocess.run(["wrk", "-t2" if args.connections > 1 else "-t1", f"-c{args.connections}",
                            f"-d{args.seconds}s", f"http://127.0.0.1:{port}/v1/devices"],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        elapsed = time.monotonic() - t0
        m = re.search(r"(\d+) requests in", w.stdout)
        requests = int(m.group(1)) if m else 0
        if tool == "callgrind":
            subprocess.run(["callgrind_control", "-d", str(d.proc.pid)], check=True, stdout=subprocess.DEVNULL)
            subprocess.run(["callgrind_control", "-i", "off", str(d.proc.pid)], check=True, stdout=subprocess.DEVNULL)
            dumps = sorted(f for f in os.listdir(b.tmp) if f.startswith("callgrind.out"))
            cg_out = os.path.join(b.tmp, next((f for f in dumps if f != "callgrind.out"), dumps[0] if dumps else "x"))
        else:
            rec.send_signal(2)
            rec.wait()
        d.stop(timeout=60)
        head = [f"# GET /v1/devices under load, profiled with {tool}",
                f"# bench/profile_devices.py --seconds {args.seconds} --connections {args.connections} "
                f"({time.strftime('%Y-%m-%d')}, commit {subprocess.run(['git', '-C', harness.ROOT, 'rev-parse', '--short', 'HEAD'], stdout=subprocess.PIPE, text=True).stdout.strip()}, "
                f"{b._build_type()} build, shared 2-core machine)",
                f"# {args.devices} real realdds devices; response {len(body)} bytes; wrk {args.connections} connections "
                f"over TCP for {elapsed:.1f} s: {requests} requests served under {tool}",
                "# perf: 'perf stat -e instructions true' -> not supported on this machine; hence callgrind"
                if tool == "callgrind" else "", ""]
        if tool == "callgrind":
            ann = subprocess.run(["callgrind_annotate", "--threshold=99", cg_out], stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT, text=True).stdout
            inc = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=99", cg_out],
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True).stdout
            total = re.search(r"([\d,]+) \(100\.0%\)\s+PROGRAM TOTALS", ann)
            ir = int(total.group(1).replace(",", "")) if total else 0
            if requests:
                head.append(f"# instructions during the load: {ir:,}; per request: {ir // requests:,}")
                head.append("")

            def top(text, n):
                lines = text.splitlines()
                start = next((i for i, l in enumerate(lines) if "file:function" in l), 0)
                return [shorten(l)[:300] for l in lines[start:start + 2 + n]]
            body_lines = ["## exclusive (self) instructions, top 40"] + top(ann, 40) + ["",
                          "## inclusive instructions, top 40"] + top(inc, 40)
        else:
            rep = subprocess.run(["perf", "report", "-i", perf_data, "--no-children", "--stdio", "--percent-limit",
                                  "0.5"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout
            body_lines = ["## perf report (self), entries above 0.5 %"] + rep.splitlines()[:120]
        text = "\n".join(head + body_lines) + "\n"
        with open(args.out, "w") as f:
            f.write(text)
        print(text)
    finally:
        for fn in reversed(b.cleanup):
            try:
                fn()
            except Exception:  # noqa: BLE001
                pass
        b.locks.release()
        shutil.rmtree(b.tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
