#!/usr/bin/env python3
"""The DDS floor for bench/run: a bare Cyclone DDS reader (PyPI `cyclonedds`) of realdds'
discovery topic `realsense/device-info`, with nothing above it.

    dds_floor_reader.py --domain D

Prints one JSON line per thing it sees, stamped with CLOCK_MONOTONIC (time.monotonic(),
the clock realdds_server.py stamps its replies with) in the listener, on Cyclone's own
thread, as soon as it is called:
    {"ready": true}                                   once the reader exists
    {"kind": "sample", "t": ..., "data": "..."}       a device-info sample
    {"kind": "matched", "t": ..., "count": N}         writers matched (a lease expiry lowers it)
Runs until stdin closes.
"""
import argparse
import json
import os
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "tools"))

from cyclonedds.core import Listener  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl.types import uint8  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402

from cyclone_peer import QOS, flexible_type  # noqa: E402  (realdds' type, as the interop tests declare it)

lock = threading.Lock()


def emit(obj):
    text = json.dumps(obj) + "\n"
    with lock:
        sys.stdout.write(text)
        sys.stdout.flush()


class OnData(Listener):
    def on_data_available(self, reader):
        t = time.monotonic()
        for sample in reader.take(N=64):
            if not hasattr(sample, "data"):  # an InvalidSample: a writer's unregistration
                continue
            emit({"kind": "sample", "t": t, "data": bytes(sample.data).decode("utf-8", "replace")})

    def on_subscription_matched(self, reader, status):
        emit({"kind": "matched", "t": time.monotonic(), "count": status.current_count})


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    args = ap.parse_args()
    participant = DomainParticipant(args.domain)
    topic = Topic(participant, "realsense/device-info", flexible_type(uint8), qos=QOS)
    reader = DataReader(participant, topic, qos=QOS, listener=OnData())
    emit({"ready": True})
    sys.stdin.read()
    del reader
    return 0


if __name__ == "__main__":
    sys.exit(main())
