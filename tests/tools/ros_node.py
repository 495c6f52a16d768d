#!/usr/bin/env python3
"""A ROS 2 node as the DDS wire shows it, from PyPI's `cyclonedds` binding (11.x),
for interop tests: no ROS 2 is installed here, and pyrealdds reads
ros_discovery_info but cannot write it.

What rmw (rmw_fastrtps, rmw_cyclonedds) puts on the wire for a node reading a
topic: a participant named "/" (its enclave), a reader on the topic, and on
"ros_discovery_info" (RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1) one
rmw_dds_common ParticipantEntitiesInfo sample naming the participant's nodes
and each node's readers and writers by GID. The GID holds 24 octets in ROS 2
Humble and 16 from Iron on (rmw_dds_common's Gid.msg); --gid-size picks one.

  ros_node.py --domain D --node /robot/viewer --topic T [--topic T2 ...]
              [--other-node /imu_filter --other-topic rt/imu]
              [--gid-size 24|16] [--about GUID]
    the node reads each T; the other node, in the same participant, writes
    rt/imu; --about names another participant in the sample (which a daemon
    must refuse). Prints {"participant": GUID, "readers": [GUID, ...]} once
    written, then stays until stdin closes.
"""
import argparse
import json
import sys
import uuid
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, sequence, uint8
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


def discovery_types(gid_size):
    @dataclass
    class Gid(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
        data: array[uint8, gid_size]

    @dataclass
    class NodeEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"):
        node_namespace: str
        node_name: str
        reader_gid_seq: sequence[Gid]
        writer_gid_seq: sequence[Gid]

    @dataclass
    class ParticipantEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"):
        gid: Gid
        node_entities_info_seq: sequence[NodeEntitiesInfo]

    return Gid, NodeEntitiesInfo, ParticipantEntitiesInfo


@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    data: sequence[uint8]


def guid_text(guid):
    """The daemon's spelling of a GUID: four groups of 8 hex digits."""
    h = guid.bytes.hex()
    return ".".join(h[i:i + 8] for i in range(0, 32, 8))


def split(name):
    ns, _, base = name.rpartition("/")
    return ns or "/", base


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--node", required=True)
    ap.add_argument("--topic", action="append", default=[])
    ap.add_argument("--other-node")
    ap.add_argument("--other-topic", default="rt/imu")
    ap.add_argument("--gid-size", type=int, choices=[16, 24], default=24)
    ap.add_argument("--about", help="a GUID (the daemon's spelling) to name instead of its own")
    args = ap.parse_args()

    dp = DomainParticipant(args.domain, qos=Qos(Policy.EntityName("/")))
    # rmw's QoS for a sensor stream reader does not matter here: the endpoint is.
    readers = [DataReader(dp, Topic(dp, t, Image)) for t in args.topic]
    others = [DataWriter(dp, Topic(dp, args.other_topic, Image))] if args.other_node else []

    Gid, NodeEntitiesInfo, ParticipantEntitiesInfo = discovery_types(args.gid_size)

    def gid(guid):
        return Gid(data=list(guid.bytes) + [0] * (args.gid_size - 16))

    nodes = [NodeEntitiesInfo(*split(args.node), reader_gid_seq=[gid(r.guid) for r in readers], writer_gid_seq=[])]
    if args.other_node:
        nodes.append(NodeEntitiesInfo(*split(args.other_node), reader_gid_seq=[],
                                      writer_gid_seq=[gid(w.guid) for w in others]))
    about = uuid.UUID(args.about.replace(".", "")) if args.about else dp.guid
    qos = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.Durability.TransientLocal,
              Policy.History.KeepLast(1),
              # rmw writes plain CDR (XCDR1), as every ROS 2 release does
              Policy.DataRepresentation(use_cdrv0_representation=True))
    writer = DataWriter(dp, Topic(dp, "ros_discovery_info", ParticipantEntitiesInfo, qos=qos), qos=qos)
    writer.write(ParticipantEntitiesInfo(gid=gid(about), node_entities_info_seq=nodes))
    print(json.dumps({"participant": guid_text(dp.guid), "readers": [guid_text(r.guid) for r in readers]}), flush=True)
    sys.stdin.read()


if __name__ == "__main__":
    main()
