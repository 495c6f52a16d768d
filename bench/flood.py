#!/usr/bin/env python3
"""rs-discoveryd under a device-info flood (issue 8): RSS and API latency.

Run on demand (not part of the test suite):
    .venv/bin/python bench/flood.py [--rate 10000] [--seconds 5] [--runs 3]

A rogue Cyclone writer (tests' rsd-raw-writer --flood) sends distinct device-info
at --rate messages/s while one client asks GET /v1/devices?product-line=none in
a loop over the Unix socket. The anchor is the same request in the same run with
no flood. Prints RSS before, peak during and 20 s after, and the latency p50/p99
with and without the flood (and their ratio).
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))

import conftest  # noqa: E402  (the test suite's daemon and realdds helpers)


def rss_kb(pid):
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))


def latencies(daemon, stop):
    out = []
    while not stop.is_set():
        t = time.perf_counter()
        status, _, _ = daemon.request("/v1/devices?product-line=none")
        out.append(time.perf_counter() - t)
        assert status == 200
    return out


def pct(values, p):
    values = sorted(values)
    return values[min(len(values) - 1, int(len(values) * p))] * 1000


def run(args, tmp, domain):
    args_d = ["--domain", str(domain), "--socket", os.path.join(tmp, "api.sock"), "--http", "off", "--no-usb",
              "--config", os.path.join(tmp, "empty.json")]
    d = conftest.Daemon(args_d, tmp, os.path.join(tmp, "api.sock"), None)
    deadline = time.monotonic() + 15
    while not d.healthy():
        assert time.monotonic() < deadline, d.log()
        time.sleep(0.05)
    time.sleep(3)  # first discovery over, steady state

    stop = threading.Event()
    quiet = []
    t = threading.Thread(target=lambda: quiet.extend(latencies(d, stop)))
    t.start()
    time.sleep(args.seconds)
    stop.set()
    t.join()
    # After the anchor's requests: API workers' memory is not the flood's.
    time.sleep(11)  # settled
    before = rss_kb(d.proc.pid)

    stop = threading.Event()
    loaded = []
    t = threading.Thread(target=lambda: loaded.extend(latencies(d, stop)))
    t.start()
    writer = subprocess.Popen([args.writer, str(domain), "--flood", str(int(args.rate * args.seconds)),
                               str(args.rate)], stdout=subprocess.PIPE, text=True)
    peak = before
    while writer.poll() is None:
        peak = max(peak, rss_kb(d.proc.pid))
        time.sleep(0.05)
    stop.set()
    t.join()
    flood_out = writer.stdout.read().split()[1:]  # "matched", then "flooded N SECONDS"
    time.sleep(20)  # the daemon hands memory back 2 s after a burst (main.cpp, kTrimAfter)
    after = rss_kb(d.proc.pid)
    d.stop()
    return {"before": before, "peak": peak, "after": after, "sent": int(flood_out[1]),
            "flood_s": float(flood_out[2]), "quiet": quiet, "loaded": loaded}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rate", type=float, default=10000)
    ap.add_argument("--seconds", type=float, default=5)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--domain", type=int, default=229)
    ap.add_argument("--daemon", default=os.path.join(HERE, "..", "build", "daemon", "rs-discoveryd"))
    ap.add_argument("--writer", default=os.path.join(HERE, "..", "build", "tests", "interop", "rsd-raw-writer"))
    args = ap.parse_args()
    conftest.DAEMON = os.path.abspath(args.daemon)
    print("| run | sent | msg/s | RSS before (kB) | peak | 20 s after | after/before | quiet p50 / p99 (ms) "
          "| flood p50 / p99 (ms) | p99 ratio |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for i in range(args.runs):
        with tempfile.TemporaryDirectory() as tmp:
            with open(os.path.join(tmp, "empty.json"), "w") as f:
                f.write("{}")
            r = run(args, tmp, args.domain)
        q99, l99 = pct(r["quiet"], 0.99), pct(r["loaded"], 0.99)
        print(f"| {i + 1} | {r['sent']} | {r['sent'] / r['flood_s']:.0f} | {r['before']} | {r['peak']} | "
              f"{r['after']} | {r['after'] / r['before']:.2f} | {statistics.median(r['quiet']) * 1000:.3f} / "
              f"{q99:.3f} | {statistics.median(r['loaded']) * 1000:.3f} / {l99:.3f} | {l99 / q99:.1f}x |",
              flush=True)


if __name__ == "__main__":
    main()
