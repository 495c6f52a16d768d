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
CLOCK_MONOTONIC of the last write}. Then,
one JSON command per stdin line, each answered with one line carrying "t" (after the
write or the deletion):
    {"cmd": "add", "info": {...}}          a new writer (participant 0) writes `info`
    {"cmd": "remove", "topic-root": "..."} deletes that writer (the daemon removes it)
Exits when stdin closes.
"""
import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "tools"))

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

    participants = [DomainParticipant(args.domain) for _ in range(args.participants)]
    topics = [Topic(p, TOPIC, flexible) for p in participants]
    pending = []  # (writer, info) not written yet
    n = args.first
    for topic, participant in zip(topics, participants):
        for _ in range(args.devices):
            pending.append((DataWriter(participant, topic, qos=QOS), device_info(args.prefix, n)))
            n += 1
    writers = [w for w, _ in pending]
    seen = [0] * len(pending)  # readers each writer has written to (total_count)
    deadline = time.monotonic() + args.match_timeout
    last = time.monotonic()
    # Discovery reaches the writers over some seconds: polled, written as each matches.
    while True:
        short = 0
        for k, (w, info) in enumerate(pending):
            total = w.get_publication_matched_status().total_count
            if total > seen[k]:
                w.write(sample(info))
                seen[k] = total
                last = time.monotonic()
            if seen[k] < args.readers:
                short += 1
        if short == 0:
            break
        if time.monotonic() > deadline:
            emit({"error": f"{short} of {len(writers)} writers matched fewer than {args.readers} readers "
                           f"within {args.match_timeout} s"})
            return 1
        time.sleep(0.05)  # a poll of Cyclone's match status, not a wait for an answer
    emit({"writers": len(writers), "t": last})

    extra = {}
    for line in sys.stdin:
        if not line.strip():
            continue
        msg = json.loads(line)
        if msg.get("cmd") == "add":
            info = msg["info"]
            w = DataWriter(participants[0], topics[0], qos=QOS)
            while w.get_publication_matched_status().current_count < args.readers:
                time.sleep(0.001)  # a poll of Cyclone's match status
            w.write(sample(info))
            extra[info["topic-root"]] = w
            emit({"ok": True, "t": time.monotonic()})
        elif msg.get("cmd") == "remove":
            w = extra.pop(msg["topic-root"], None)
            if w is None:
                emit({"ok": False, "error": "no such writer"})
                continue
            t = time.monotonic()
            del w  # the last reference: Cyclone deletes the writer, the daemon sees it go
            emit({"ok": True, "t": t})
        else:
            emit({"ok": False, "error": f"unknown command {msg!r}"})
    return 0


if __name__ == "__main__":
    sys.exit(main())
