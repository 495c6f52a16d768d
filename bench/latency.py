#!/usr/bin/env python3
"""Discovery and removal latency of rs-discoveryd against real realdds servers.

Run on demand (not part of the test suite):
    .venv/bin/python bench/latency.py [--runs 10] [--daemon build/daemon/rs-discoveryd]

Measures, with the daemon warm and an event stream open, from the realdds
server's call (CLOCK_MONOTONIC, shared by all processes here) to the SSE event:
  - discovery: device_server.broadcast() -> `added`
  - stopping:  broadcast_disconnect()    -> `removed`
  - SIGKILL:   kill -9 of the server     -> `removed` (lease expiry)
and prints the medians, min and max.
"""
import argparse
import os
import signal
import statistics
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))

import conftest  # noqa: E402  (the test suite's daemon and realdds helpers)


def summary(name, values):
    ms = [v * 1000 for v in values]
    print(f"{name:>10}: median {statistics.median(ms):7.1f} ms   min {min(ms):7.1f}   max {max(ms):7.1f}"
          f"   (n={len(ms)})")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--domain", type=int, default=231)
    ap.add_argument("--daemon", default=os.path.join(HERE, "..", "build", "daemon", "rs-discoveryd"))
    args = ap.parse_args()
    conftest.DAEMON = os.path.abspath(args.daemon)

    tmp = tempfile.mkdtemp(prefix="rsd-bench-")
    port = conftest.free_port()
    d = conftest.Daemon(["--domain", str(args.domain), "--socket", os.path.join(tmp, "api.sock"),
                         "--http", f"127.0.0.1:{port}", "--no-usb"], tmp, os.path.join(tmp, "api.sock"), port)
    d.wait_ready()
    events = conftest.EventStream(d)
    discovery, stopping, killed = [], [], []
    try:
        for run in range(args.runs):
            info = conftest.device_info(run % 90)
            server = conftest.RealddsServer(args.domain, [])
            reply = server.command(cmd="add", info=info)
            ev = events.next(timeout=15)
            discovery.append(time.monotonic() - reply["t"])
            assert ev["event"] == "added", ev
            reply = server.command(cmd="disconnect", **{"topic-root": info["topic-root"]})
            ev = events.next(timeout=15)
            stopping.append(time.monotonic() - reply["t"])
            assert ev["event"] == "removed", ev
            server.command(cmd="add", info=dict(info, **{"topic-root": info["topic-root"] + "_k"}))
            assert events.next(timeout=15)["event"] == "added"
            t = time.monotonic()
            server.proc.send_signal(signal.SIGKILL)
            ev = events.next(timeout=30)
            killed.append(time.monotonic() - t)
            assert ev["event"] == "removed", ev
            server.proc.wait()
    finally:
        events.close()
        d.stop()
    # The event arrives on a reader thread; its queue hand-off adds well under 1 ms.
    summary("discovery", discovery)
    summary("stopping", stopping)
    summary("SIGKILL", killed)


if __name__ == "__main__":
    main()
