#!/usr/bin/env python3
"""Many device-info writers in one process, for the 10,000-camera bench (bench/scale_large.py).

A realdds server costs a Python process, Fast DDS and a dozen endpoints per device; ten
thousand of them do not fit a 2-core machine. What the daemon sees of a camera on
`realsense/device-info` is one writer and its one sample, so the bulk of the bench is
raw writers from PyPI's `cyclonedds` (the realdds type and QoS of tests/tools/cyclone_peer.py),
with realdds servers among them.

    raw_writers.py --domain D --participants P --devices N --prefix X

makes P participants on domain D, each with N writers (one per camera, as realdds has one
per device server), and writes each camera's device-info each time a reader matches the
writer, as realdds broadcasts on a match (the topic is VOLATILE: a sample written before
the match is lost). The participants share one process, so they match each other
locally, without the proxies a remote peer costs. Prints one JSON line once every writer
has met --readers readers (the daemons of the bench): {"writers": P*N, "t":
CLOCK_MONOTONIC as the last write began}. Then,
one JSON command per stdin line, each answered with one line carrying "t" (as the
write began, or once the writer is deleted):
    {"cmd": "add", "info": {...}}          a new writer (participant 0) writes `info`
    {"cmd": "remove", "topic-root": "..."} deletes that writer (the daemon removes it)
Exits when stdin closes.
"""
import argparse
import json
import os
import queue
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "tools"))

from cyclonedds.core import Listener  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl.types import byte  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402

from cyclone_peer import QOS, flexible_data_format, flexible_type  # noqa: E402

TOPIC = "realsense/device-info"


def device_info(prefix, n):
    serial = f"{prefix}{n:011d}"
    return {"name": "Intel RealSense D455", "serial": serial, "product-line": "D400", "product-id": "0B5C",
            "fw-version": "5.16.0.1", "topic-root": f"realsense/D455_{serial}"}


def emit(obj):
    print(json.dumps(obj), flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--participants", type=int, default=1)
    ap.add_argument("--devices", type=int, default=1, help="writers (cameras) per participant")
    ap.add_argument("--prefix", default="7", help="serials are PREFIX followed by 11 digits")
    ap.add_argument("--first", type=int, default=0, help="number of the first camera")
    ap.add_argument("--readers", type=int, default=1, help="readers every writer must meet before it reports")
    ap.add_argument("--match-timeout", type=float, default=120)
    args = ap.parse_args()
    flexible = flexible_type(byte)

    def sample(info):
        return flexible(data_format=flexible_data_format(0), version=[0, 0, 0, 0],
                        data=list(json.dumps(info).encode()))

    # realdds broadcasts a device's info on every new match, for as long as the server
    # lives; so does each writer here: its listener queues it, the worker writes (never
    # inside Cyclone's listener thread).
    matches = queue.Queue()
    readers_met = {}  # writer index -> readers matched so far (total_count)
    met_all = threading.Event()
    short = [0]
    lock = threading.Lock()

    class OnMatch(Listener):
        def __init__(self, index):
            super().__init__()
            self.index = index

        def on_publication_matched(self, writer, status):
            if status.current_count_change > 0:
                matches.put((self.index, writer))

    participants = [DomainParticipant(args.domain) for _ in range(args.participants)]
    topics = [Topic(p, TOPIC, flexible) for p in participants]
    writers, infos, built = [], [], []  # built[k]: writers[k] is set
    n = args.first
    for topic, participant in zip(topics, participants):
        for _ in range(args.devices):
            infos.append(device_info(args.prefix, n))
            writers.append(None)
            built.append(threading.Event())
            n += 1
    initial = short[0] = len(writers)
    last = [time.monotonic()]

    def serve():
        while True:
            item = matches.get()
            if item is None:
                return
            k, w = item
            if w is None:  # matched while its constructor ran: Python has no object for it yet
                built[k].wait()
                w = writers[k]
            if w is None:  # removed meanwhile
                continue
            t_write = time.monotonic()
            w.write(sample(infos[k]))
            item = None  # no reference kept here: `remove` deletes a writer by dropping its last one
            with lock:
                last[0] = t_write
                total = w.get_publication_matched_status().total_count
                if k < initial and readers_met.get(k, 0) < args.readers <= total:
                    short[0] -= 1
                    if short[0] == 0:
                        met_all.set()
                readers_met[k] = total
            w = None

    worker = threading.Thread(target=serve, daemon=True)
    worker.start()
    k = 0
    for topic, participant in zip(topics, participants):
        for _ in range(args.devices):
            writers[k] = DataWriter(participant, topic, qos=QOS, listener=OnMatch(k))
            built[k].set()
            k += 1
    if not met_all.wait(args.match_timeout):
        emit({"error": f"{short[0]} of {len(writers)} writers matched fewer than {args.readers} readers "
                       f"within {args.match_timeout} s"})
        return 1
    emit({"writers": len(writers), "t": last[0]})

    extra = {}
    for line in sys.stdin:
        if not line.strip():
            continue
        msg = json.loads(line)
        if msg.get("cmd") == "add":
            info = msg["info"]
            k = len(infos)
            infos.append(info)
            writers.append(None)
            built.append(threading.Event())
            ready = threading.Event()
            w = DataWriter(participants[0], topics[0], qos=QOS, listener=OnMatch(k))
            writers[k] = w
            built[k].set()
            extra[info["topic-root"]] = w
            # Answered once every reader has been written to (the worker's broadcast).
            while readers_met.get(k, 0) < args.readers:
                ready.wait(0.001)
            emit({"ok": True, "t": last[0]})
        elif msg.get("cmd") == "remove":
            w = extra.pop(msg["topic-root"], None)
            if w is not None:
                writers[writers.index(w)] = None
            if w is None:
                emit({"ok": False, "error": "no such writer"})
                continue
            t0 = time.monotonic()
            # The last reference: Cyclone deletes the writer. That blocks while the
            # writer lingers for its readers' acks (~200 ms here): "t" is when it is
            # gone, "t_asked" when the deletion began.
            del w
            emit({"ok": True, "t": time.monotonic(), "t_asked": t0})
        else:
            emit({"ok": False, "error": f"unknown command {msg!r}"})
    return 0


if __name__ == "__main__":
    sys.exit(main())
