#!/usr/bin/env python3
"""A hostile or broken sharer on rs-discoveryd/shared-usb (proto/shared_usb.idl),
from PyPI's `cyclonedds` binding, for the sharing tests: what a daemon must cap,
count and survive. The type is declared from the IDL with the same names, so it
matches the daemon's by type name.

  share_peer.py --domain D   prints {"matched": true} once a reader is matched;
      then each stdin line is one sample written, answered {"ok": true}:
        {"host": H, "camera": C, "version": V, "data": TEXT}   one sample
        {"flood": N, "host": H}   N valid cameras usb-flood-0..N-1 of host H
      stays (its samples with it) until stdin closes
"""
import argparse
import json
import sys
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final, key
from cyclonedds.idl.types import bounded_str, byte, sequence, uint8
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from cyclone_peer import commands, emit, matched_writer  # the same start: a writer once a reader matched


@dataclass
@final
class usb_camera(IdlStruct, typename="rsd::share::usb_camera"):
    host: bounded_str[64]
    key("host")
    camera: bounded_str[96]
    key("camera")
    version: uint8
    data: sequence[byte, 4096]


QOS = Qos(Policy.Reliability.Reliable(duration(seconds=10)), Policy.Durability.TransientLocal,
          Policy.History.KeepLast(1))


def camera_doc(host, serial):
    return json.dumps({"host": {"name": host, "addresses": ["192.0.2.9"]},
                       "device": {"name": "Intel RealSense D455", "serial": serial, "product-id": "0B5C"}})


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    args = ap.parse_args()
    participant = DomainParticipant(args.domain)
    topic = Topic(participant, "rs-discoveryd/shared-usb", usb_camera, qos=QOS)
    writer = matched_writer(participant, topic, QOS)
    if writer is None:
        return 1
    for msg in commands():
        if "flood" in msg:
            for i in range(msg["flood"]):
                cam = f"usb-flood-{i}"
                writer.write(usb_camera(host=msg["host"], camera=cam, version=1,
                                        data=list(camera_doc(msg["host"], f"flood-{i}").encode())))
        else:
            writer.write(usb_camera(host=msg["host"], camera=msg["camera"], version=msg.get("version", 1),
                                    data=list(msg["data"].encode())))
        emit({"ok": True})
    return 0


if __name__ == "__main__":
    sys.exit(main())
