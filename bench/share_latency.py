"""A USB camera plugged on host A, listed on host B: how long the share takes.

Two hosts of their own (network namespaces on one switch, each with its own
umockdev bus and daemon, as tests/share does), sharing on. Each round plugs a
camera on A and unplugs it again; both daemons' event streams are read on
threads, each event stamped on arrival, so the figures are:
  plug -> A added       the local hotplug path (umockdev's uevent, libusb, the table)
  A added -> B added    the share itself: A's main loop woken, the announcement
                        written, DDS delivery between the namespaces, B's table
  unplug -> A removed, A removed -> B removed   the same on the way out.

Runs as root under umockdev-wrapper (it re-executes itself under it when not);
prints one JSON object. bench/run's "share" section calls it; alone:
  umockdev-wrapper .venv/bin/python bench/share_latency.py --build build --rounds 20
"""
import argparse
import json
import os
import statistics
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path[:0] = [os.path.join(ROOT, "tests"), os.path.join(ROOT, "tests", "share")]


def summary(values_ms):
    v = sorted(values_ms)
    return {"n": len(v), "median": round(statistics.median(v), 3), "min": round(v[0], 3),
            "max": round(v[-1], 3), "p90": round(v[min(len(v) - 1, int(len(v) * 0.9))], 3)}


def measure(rounds):
    from conftest import DomainLocks, EventStream
    from sharebed import D455, Site

    locks = DomainLocks()
    site = Site(2, tempfile.mkdtemp(prefix="rsd-share-bench-"), locks.take())
    try:
        a, b = site.start(0), site.start(1)
        ea, eb = EventStream(a), EventStream(b)
        here, there = f"usb-{D455}", f"usb-{D455}.host0"
        times = {k: [] for k in ("plug_to_a", "a_to_b", "unplug_to_a", "a_to_b_removed")}

        def event_of(stream, kind, dev_id):
            while True:
                ev = stream.next(timeout=10, types=(kind,))
                if ev.get("json", {}).get("id") == dev_id or ev.get("json", {}).get("device", {}).get("id") == dev_id:
                    return ev

        for i in range(rounds):
            t0 = time.monotonic()
            path = site.beds[0].plug("d455-usb3", devnum=10 + i % 100)
            ta = event_of(ea, "added", here)["t"]
            tb = event_of(eb, "added", there)["t"]
            times["plug_to_a"].append((ta - t0) * 1000)
            times["a_to_b"].append((tb - ta) * 1000)
            t0 = time.monotonic()
            site.beds[0].unplug(path)
            ta = event_of(ea, "removed", here)["t"]
            tb = event_of(eb, "removed", there)["t"]
            times["unplug_to_a"].append((ta - t0) * 1000)
            times["a_to_b_removed"].append((tb - ta) * 1000)
        ea.close()
        eb.close()
        return {k: summary(v) for k, v in times.items()}
    finally:
        try:
            site.close()
        finally:
            locks.release()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"), help="the build tree (default: build)")
    ap.add_argument("--rounds", type=int, default=20, help="plug/unplug rounds (default: 20)")
    args = ap.parse_args()
    if "umockdev" not in os.environ.get("LD_PRELOAD", ""):
        os.execvp("umockdev-wrapper", ["umockdev-wrapper", sys.executable] + sys.argv)
    os.environ["RSD_DAEMON"] = os.path.join(os.path.abspath(args.build), "daemon", "rs-discoveryd")
    print(json.dumps({"rounds": args.rounds, **measure(args.rounds)}))


if __name__ == "__main__":
    main()
