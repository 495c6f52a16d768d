"""A realdds client of a camera, listed as one: how long after DDS discovery.

One daemon on a domain of its own, with Cyclone's discovery trace on (its
timestamps say when the daemon's own DDS stack took each endpoint of a peer), the
suite's realdds server serving one D555 (tests/tools/realdds_server.py, spec d555),
and an observer: a participant of PyPI's `cyclonedds` (another DDS stack) reading
the DCPSPublication and DCPSSubscription built-in topics, which stamps each
endpoint on the camera's topics as its discovery delivers it. Each round starts a
realdds client (tests/tools/realdds_client.py: pyrealdds' dds.device on the camera,
no streams), then makes it quit cleanly, and times:

  device -> daemon's DDS  the client makes its dds.device -> the daemon's Cyclone
                          takes the client's first endpoint on the camera's topics
                          (its trace's "SEDP ST0 ... NEW"): DDS discovery itself
  daemon's DDS -> listed  that -> the daemon's `changed` event (the camera's in-use
                          summary counting the client) read on /v1/events: the
                          daemon's own share, target <= 100 ms
  device -> observer      the same discovery by the observer, another stack: an
                          anchor for what any DDS reader gets
  device -> listed        the whole, as a user sees it
  quit -> unlisted        the client told to quit -> the `changed` event without it

plus the `changed` events each coming and going brought beyond the first (none:
one each, however many endpoints). Times are time.monotonic() (one clock for every
process of the host); the trace's wall-clock times are brought onto it by the
offset measured at the start. Prints one JSON object; bench/run's "clients" section
calls it; alone:
  .venv/bin/python bench/client_latency.py --build build --rounds 20
"""
import argparse
import json
import os
import queue
import re
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path[:0] = [HERE, os.path.join(ROOT, "tests")]

SERIAL = "555777001"
INFO = {"name": "Intel RealSense D555", "serial": SERIAL, "product-line": "D500", "product-id": "0B56",
        "topic-root": f"realsense/D555_{SERIAL}"}


def observe(domain, root):
    """The observer (run as a child): one JSON line per endpoint on the camera's topics
    its DDS discovery delivers, {"participant", "topic", "t"}, and {"ready": true} first."""
    from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication, BuiltinTopicDcpsSubscription
    from cyclonedds.core import Listener
    from cyclonedds.domain import DomainParticipant

    lock = threading.Lock()

    def on_data(_):
        t = time.monotonic()
        for s in (x for r in readers for x in r.take(N=256)):
            topic = getattr(s, "topic_name", None)
            if not topic or not (topic.startswith(root + "/") or topic.startswith("rt/" + root + "_")):
                continue
            with lock:
                print(json.dumps({"participant": str(s.participant_key), "topic": topic, "t": t}), flush=True)

    p = DomainParticipant(domain)
    readers = []
    readers += [BuiltinDataReader(p, topic, listener=Listener(on_data_available=on_data))
               for topic in (BuiltinTopicDcpsPublication, BuiltinTopicDcpsSubscription)]
    print(json.dumps({"ready": True, "participant": str(p.guid)}), flush=True)
    sys.stdin.readline()
    del readers


# A client's endpoints on a camera's topics as Cyclone's discovery trace takes them: its
# control writer and its notification reader (a server has the other two directions).
SEDP_NEW = re.compile(r"^(\d+\.\d+) .*SEDP ST0 ([0-9a-f]+:[0-9a-f]+):\S+ \S+ \S+ (reader|writer) .*\.(\S+)/"
                      r"(notification|control)/\S+ p\(\S+\) NEW")


def daemon_discoveries(trace_path, root):
    """{participant prefix: the wall-clock time its first client endpoint on `root` was
    taken}, from the daemon's Cyclone trace, in the order the participants came."""
    out = {}
    with open(trace_path, errors="replace") as f:
        for line in f:
            m = SEDP_NEW.match(line)
            if not m or m.group(4) != root:
                continue
            client_side = (m.group(3), m.group(5)) in (("reader", "notification"), ("writer", "control"))
            if client_side and m.group(2) not in out:
                out[m.group(2)] = float(m.group(1))
    return out


def measure(build, rounds):
    import conftest
    from bench_common import BenchError, Lines, log, stats, wait_until

    locks = conftest.DomainLocks()
    domain = locks.take()
    tmp = tempfile.mkdtemp(prefix="rsd-client-latency-")
    cleanup = []
    try:
        sock = os.path.join(tmp, "d.sock")
        cfg = os.path.join(tmp, "config.json")
        with open(cfg, "w") as f:
            f.write("{}")
        conftest.DAEMON = os.path.join(os.path.abspath(build), "daemon", "rs-discoveryd")
        trace = os.path.join(tmp, "cyclone-trace.log")
        uri = f"<Tracing><Category>discovery</Category><OutputFile>{trace}</OutputFile></Tracing>"
        d = conftest.Daemon(["--domain", str(domain), "--config", cfg, "--socket", sock, "--no-usb",
                             "--log-level", "warning"], tmp, sock, None, env={"CYCLONEDDS_URI": uri})
        # The trace's clock (wall) onto time.monotonic(): the smallest offset of a few reads.
        offset = min(time.time() - time.monotonic() for _ in range(5))
        cleanup.append(d.stop)
        server = conftest.RealddsServer(domain, [], name="bench-d555-server")
        cleanup.append(server.kill)
        server.command(cmd="add", info=INFO, spec="d555")
        cam = f"dds-{domain}-" + INFO["topic-root"].replace("/", ".")
        wait_until(lambda: cam in d.device_ids(), 30, "the camera listed")
        observer = Lines([sys.executable, os.path.abspath(__file__), "--observe", str(domain), INFO["topic-root"]])
        cleanup.append(observer.close)
        observer.wait(lambda x: x.get("ready"), 20, "the observer")
        events = conftest.EventStream(d, query=f"?serial={SERIAL}")
        cleanup.append(events.close)

        def first_change(timeout, what):
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                try:
                    ev = events.events.get(timeout=max(deadline - time.monotonic(), 0.001))
                except queue.Empty:
                    break
                if ev is None:
                    raise BenchError("the event stream ended")
                if ev.get("event") == "changed":
                    return ev
            raise BenchError(f"no `changed` event within {timeout} s: {what}")

        legs = {k: [] for k in ("device_to_daemon_dds", "daemon_dds_to_listed", "device_to_observer",
                                "device_to_listed", "quit_to_unlisted")}
        listed_at = []  # per round: (when it made its device, when it was listed)
        extra_changes = {"coming": 0, "going": 0}
        client_tool = os.path.join(ROOT, "tests", "tools", "realdds_client.py")
        for i in range(rounds):
            observer.drain()
            client = Lines([sys.executable, client_tool, "--domain", str(domain), "--name", f"bench-client-{i}",
                            "--info", json.dumps(INFO)])
            cleanup.append(client.close)
            made = client.wait(lambda x: "device" in x, 30, "the client making its device")["device"]
            ev = first_change(10, "the client listed")
            if (ev.get("json", {}).get("in-use") or {}).get("clients") != 1:
                raise BenchError(f"round {i}: the first change is not the client's: {ev.get('json')}")
            client.wait(lambda x: "ready" in x, 30, "the client ready")
            seen = [x for x in observer.drain() if x.get("t", 0) >= made]
            if not seen:
                seen = [observer.wait(lambda x: x.get("t", 0) >= made, 10, "the observer's discovery")]
            first = min(x["t"] for x in seen)
            legs["device_to_observer"].append((first - made) * 1000)
            legs["device_to_listed"].append((ev["t"] - made) * 1000)
            listed_at.append((made, ev["t"]))
            log(f"round {i}: device -> observer {(first - made) * 1000:.1f} ms, -> listed {(ev['t'] - made) * 1000:.1f} ms")
            extra_changes["coming"] += len(events.within(0.3))
            t0 = time.monotonic()
            client.proc.stdin.write("quit\n")
            client.proc.stdin.flush()
            ev = first_change(10, "the client unlisted")
            if "in-use" in ev.get("json", {}):
                raise BenchError(f"round {i}: still in use after the client quit: {ev.get('json')}")
            legs["quit_to_unlisted"].append((ev["t"] - t0) * 1000)
            client.close()
            extra_changes["going"] += len(events.within(0.3))
        # The daemon's own discovery of each round's client, from its trace (written by
        # now: Cyclone flushes each line).
        found = list(daemon_discoveries(trace, INFO["topic-root"]).values())
        if len(found) != rounds:
            raise BenchError(f"the daemon's trace has {len(found)} clients' discoveries, not {rounds}")
        for (made, listed), wall in zip(listed_at, found):
            taken = wall - offset
            legs["device_to_daemon_dds"].append((taken - made) * 1000)
            legs["daemon_dds_to_listed"].append((listed - taken) * 1000)
        out = {"rounds": rounds, **{k: stats(v) for k, v in legs.items()},
               "extra_changed_events": extra_changes,
               "note": "daemon's DDS: its Cyclone discovery trace (SEDP NEW); observer: PyPI cyclonedds "
                       "reading DCPSPublication/DCPSSubscription; client: pyrealdds dds.device "
                       "(realdds_client.py), no streams; quit -> unlisted includes the daemon's 50 ms "
                       "hold of a summary that loses a client"}
        return out
    finally:
        for fn in reversed(cleanup):
            try:
                fn()
            except Exception:  # noqa: BLE001
                pass
        locks.release()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"), help="the build tree (default: build)")
    ap.add_argument("--rounds", type=int, default=20, help="clients, one after another (default: 20)")
    ap.add_argument("--observe", nargs=2, metavar=("DOMAIN", "ROOT"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.observe:
        observe(int(args.observe[0]), args.observe[1])
        return
    print(json.dumps(measure(args.build, args.rounds)))


if __name__ == "__main__":
    main()
