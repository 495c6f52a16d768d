#!/usr/bin/env python3
"""A Cyclone DDS peer on realsense/device-info from PyPI's `cyclonedds` binding
(11.x, with its own libddsc), driven over stdin, for interop tests.

It is what a user may run beside the daemon: a newer Cyclone whose endpoints
carry XTypes type information, which the daemon's older libddsc must never ask
for (asking crashed it: issue 8). The type is declared here from realdds' IDL
(proto/flexible.idl), with the same names, so it matches by type name.

Two spellings of realdds' `octet`: `--octet byte` gives the same XTypes type id
as Cyclone's idlc; `--octet uint8` (what a Python user may well write) gives
another one, so a reader that asks for type objects starts a type lookup.

  cyclone_peer.py --domain D writer   prints {"matched": true} once a reader on
      the topic is matched; then each stdin line {"json": {...}} or
      {"raw": "HEX", "format": N} is written as one sample, answered {"ok": true}
  cyclone_peer.py --domain D --topic T writer   the same on another flexible topic
      (T = <topic-root>/notification: a server's notifications, made up by the test)
  cyclone_peer.py --domain D --device JSON [--lose-first N] announcer   plays a
      realdds server's device writer: writes the device-info each time a reader
      matches, as realdds does, but for the first N matches, whose broadcast is
      lost as the race of ../shared/realdds-wire.md loses it; prints
      {"matched": K, "sent": true|false} per match; stays until stdin closes
  cyclone_peer.py --domain D reader   prints one JSON line per sample it receives
      ({"format": N, "data": "..."}); stays until stdin closes
"""
import argparse
import json
import sys
import threading
from dataclasses import dataclass

from cyclonedds.core import Listener, Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlEnum, IdlStruct
from cyclonedds.idl.types import array, byte, sequence, uint8
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


class flexible_data_format(IdlEnum, typename="realdds::topics::raw::flexible_data_format"):
    FLEXIBLE_DATA_JSON = 0
    FLEXIBLE_DATA_CBOR = 1
    FLEXIBLE_DATA_CUSTOM = 2


def flexible_type(octet):
    @dataclass
    class flexible(IdlStruct, typename="realdds::topics::raw::flexible"):
        data_format: flexible_data_format
        version: array[octet, 4]
        data: sequence[octet, 4096]
    return flexible


QOS = Qos(Policy.Reliability.Reliable(duration(seconds=10)), Policy.Durability.Volatile)


def emit(obj):
    print(json.dumps(obj), flush=True)


def matched_writer(participant, topic, qos):
    """A writer on `topic` once a reader has matched it, said on stdout ({"matched":
    true}); None (and an error line) when none matched within 30 s. Shared with
    share_peer.py."""
    matched = threading.Event()

    class OnMatch(Listener):
        def on_publication_matched(self, writer, status):
            if status.current_count > 0:
                matched.set()

    writer = DataWriter(participant, topic, qos=qos, listener=OnMatch())
    if not matched.wait(30):
        emit({"error": "no reader matched within 30 s"})
        return None
    emit({"matched": True})
    return writer


def commands():
    """The test's commands, one JSON object per stdin line, until stdin closes."""
    for line in sys.stdin:
        if line.strip():
            yield json.loads(line)


def run_writer(participant, topic, flexible):
    writer = matched_writer(participant, topic, QOS)
    if writer is None:
        return 1
    for msg in commands():
        if "json" in msg:
            data, fmt = json.dumps(msg["json"]).encode(), 0
        else:
            data, fmt = bytes.fromhex(msg["raw"]), msg.get("format", 0)
        writer.write(flexible(data_format=flexible_data_format(fmt), version=[0, 0, 0, 0], data=list(data)))
        emit({"ok": True})
    return 0


def run_announcer(participant, topic, flexible, device, lose_first):
    import queue
    matches = queue.Queue()

    class OnMatch(Listener):
        def on_publication_matched(self, writer, status):
            if status.current_count_change > 0:
                matches.put(status.total_count)

    writer = DataWriter(participant, topic, qos=QOS, listener=OnMatch())
    data = list(json.dumps(device).encode())
    emit({"announcing": True})

    def serve():  # writes outside Cyclone's listener thread
        while True:
            total = matches.get()
            if total is None:
                return
            sent = total > lose_first
            if sent:
                writer.write(flexible(data_format=flexible_data_format(0), version=[0, 0, 0, 0], data=data))
            emit({"matched": total, "sent": sent})

    worker = threading.Thread(target=serve, daemon=True)
    worker.start()
    sys.stdin.read()  # until the test closes our stdin
    matches.put(None)
    worker.join(5)
    return 0


def run_reader(participant, topic):
    class OnData(Listener):
        def on_data_available(self, reader):
            for sample in reader.take(N=64):
                emit({"format": int(sample.data_format.value),
                      "data": bytes(sample.data).decode("utf-8", "replace")})

    reader = DataReader(participant, topic, qos=QOS, listener=OnData())
    emit({"reading": True})
    sys.stdin.read()  # until the test closes our stdin
    del reader
    return 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--octet", choices=["byte", "uint8"], default="uint8")
    ap.add_argument("--topic", default="realsense/device-info",
                    help="another flexible topic, e.g. <topic-root>/notification to play a server's side")
    ap.add_argument("--device", type=json.loads, help="announcer: the device-info it announces")
    ap.add_argument("--lose-first", type=int, default=0, help="announcer: matches whose broadcast is lost")
    ap.add_argument("role", choices=["writer", "reader", "announcer"])
    args = ap.parse_args()
    flexible = flexible_type(byte if args.octet == "byte" else uint8)
    participant = DomainParticipant(args.domain)
    topic = Topic(participant, args.topic, flexible, qos=QOS)
    if args.role == "writer":
        return run_writer(participant, topic, flexible)
    if args.role == "announcer":
        return run_announcer(participant, topic, flexible, args.device, args.lose_first)
    return run_reader(participant, topic)


if __name__ == "__main__":
    sys.exit(main())
