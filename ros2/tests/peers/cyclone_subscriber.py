#!/usr/bin/env python3
"""An independent DDS peer of the ROS 2 bridge: Eclipse Cyclone DDS (the `cyclonedds` package)
subscribing to a bridge topic with the ROS 2 DDS type names, with no ROS installation.

The ROS 2 types are written here as Cyclone IDL dataclasses, from their .msg definitions (ROS 2
maps `pkg/msg/Name` to the DDS type `pkg::msg::dds_::Name_` and topic `/x` to `rt/x`).

Prints one JSON object per line on stdout: {"ready": true} once the reader exists, then one line
per sample (`recv_s` = receive time on this host's monotonic clock), then {"done": true, ...}.

    cyclone_subscriber.py --topic rt/joint_states --type joint_state --count 500 --timeout 30
"""

import argparse
import json
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos, ReadCondition, SampleState, ViewState, InstanceState, WaitSet
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int32, sequence, uint32
import cyclonedds.idl.annotations as annotate
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
@annotate.final
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
@annotate.final
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
@annotate.final
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


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


@dataclass
@annotate.final
class InertiaStamped(IdlStruct, typename="geometry_msgs::msg::dds_::InertiaStamped_"):
    header: Header
    inertia: Inertia


def joint_state(s, recv_s):
    return {
        "recv_s": recv_s,
        "sec": s.header.stamp.sec,
        "nanosec": s.header.stamp.nanosec,
        "frame_id": s.header.frame_id,
        "name": list(s.name),
        "position": list(s.position),
        "velocity": list(s.velocity),
        "effort": list(s.effort),
    }


def inertia_stamped(s, recv_s):
    i = s.inertia
    return {
        "recv_s": recv_s,
        "sec": s.header.stamp.sec,
        "nanosec": s.header.stamp.nanosec,
        "frame_id": s.header.frame_id,
        "m": i.m,
        "com": [i.com.x, i.com.y, i.com.z],
        "inertia": [i.ixx, i.ixy, i.ixz, i.iyy, i.iyz, i.izz],
    }


TYPES = {
    # name: (type, to JSON, transient-local reader)
    "joint_state": (JointState, joint_state, False),
    "inertia_stamped": (InertiaStamped, inertia_stamped, True),
}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--topic", required=True, help="DDS topic, e.g. rt/joint_states")
    p.add_argument("--type", required=True, choices=sorted(TYPES))
    p.add_argument("--domain", type=int, default=0)
    p.add_argument("--count", type=int, default=0, help="stop after this many samples (0: no limit)")
    p.add_argument("--timeout", type=float, default=30.0, help="stop after this many seconds")
    p.add_argument("--summary", action="store_true", help="print only the final line (with the rate)")
    a = p.parse_args()
    ty, to_json, latched = TYPES[a.type]

    if latched:
        qos = Qos(
            Policy.Reliability.Reliable(duration(seconds=1)),
            Policy.Durability.TransientLocal,
            Policy.History.KeepLast(1),
        )
    else:
        # Best effort matches the bridge's reliable writer and never slows it down.
        qos = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(100))
    dp = DomainParticipant(a.domain)
    topic = Topic(dp, a.topic, ty)
    reader = DataReader(dp, topic, qos=qos)
    cond = ReadCondition(reader, ViewState.Any | InstanceState.Any | SampleState.NotRead)
    ws = WaitSet(dp)
    ws.attach(cond)
    print(json.dumps({"ready": True}), flush=True)

    start = time.monotonic()
    deadline = start + a.timeout
    n = 0
    first = last = None
    while time.monotonic() < deadline and (a.count == 0 or n < a.count):
        ws.wait(duration(milliseconds=50))
        for s in reader.take(N=256, condition=cond):
            now = time.monotonic()
            first = now if first is None else first
            last = now
            n += 1
            if not a.summary:
                print(json.dumps(to_json(s, now)), flush=False)
            if a.count and n >= a.count:
                break
        sys.stdout.flush()
    rate = (n - 1) / (last - first) if n > 1 and last > first else 0.0
    print(json.dumps({"done": True, "samples": n, "rate_hz": rate}), flush=True)


if __name__ == "__main__":
    main()
