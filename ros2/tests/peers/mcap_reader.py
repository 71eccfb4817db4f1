#!/usr/bin/env python3
"""An independent reader of the service's MCAP recordings: the `mcap` package (Foxglove's reader)
with `mcap-ros2-support`, which decodes each message from the `ros2msg` schema stored in the file
(no ROS installation, no generated types).

Prints one JSON object per line on stdout: {"header": ...} (profile, library), {"summary": ...}
(statistics, per-topic counts, schemas, chunk compressions), {"metadata": ...} per metadata
record, then one {"topic": ..., "log_time": ..., ...} line per decoded message, in file order.
NaN becomes null (JSON has no NaN).

    mcap_reader.py FILE.mcap
"""

import json
import math
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def num(v):
    v = float(v)
    return None if math.isnan(v) else v


def nums(values):
    return [num(v) for v in values]


def stamp(header):
    return {"sec": header.stamp.sec, "nanosec": header.stamp.nanosec, "frame_id": header.frame_id}


def fields(schema_name, m):
    if schema_name == "sensor_msgs/msg/JointState":
        return {
            "header": stamp(m.header),
            "name": list(m.name),
            "position": nums(m.position),
            "velocity": nums(m.velocity),
            "effort": nums(m.effort),
        }
    if schema_name == "geometry_msgs/msg/InertiaStamped":
        i = m.inertia
        return {
            "header": stamp(m.header),
            "m": num(i.m),
            "com": nums([i.com.x, i.com.y, i.com.z]),
            "inertia": nums([i.ixx, i.ixy, i.ixz, i.iyy, i.iyz, i.izz]),
        }
    if schema_name == "geometry_msgs/msg/WrenchStamped":
        w = m.wrench
        return {
            "header": stamp(m.header),
            "force": nums([w.force.x, w.force.y, w.force.z]),
            "torque": nums([w.torque.x, w.torque.y, w.torque.z]),
        }
    if schema_name == "fri_msgs/msg/Collision":
        return {
            "header": stamp(m.header),
            "cycle": m.cycle,
            "joint_names": list(m.joint_names),
            "over_threshold": [bool(b) for b in m.over_threshold],
            "residual": nums(m.residual),
            "link": m.link,
        }
    if schema_name == "std_msgs/msg/String":
        return {"data": m.data}
    raise SystemExit(f"unexpected schema {schema_name}")


def main():
    path = sys.argv[1]
    out = sys.stdout
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        print(json.dumps({"header": {"profile": header.profile, "library": header.library}}), file=out)
        summary = reader.get_summary()
        stats = summary.statistics
        topics = {c.id: c.topic for c in summary.channels.values()}
        print(
            json.dumps(
                {
                    "summary": {
                        "message_count": stats.message_count,
                        "chunk_count": stats.chunk_count,
                        "message_start_time": stats.message_start_time,
                        "message_end_time": stats.message_end_time,
                        "counts": {topics[k]: v for k, v in stats.channel_message_counts.items()},
                        "compressions": sorted({c.compression for c in summary.chunk_indexes}),
                        "indexed_chunks": sum(1 for c in summary.chunk_indexes if c.message_index_offsets),
                        "schemas": {
                            s.name: s.encoding for s in summary.schemas.values()
                        },
                        "encodings": sorted({c.message_encoding for c in summary.channels.values()}),
                    }
                }
            ),
            file=out,
        )
        for m in reader.iter_metadata():
            print(json.dumps({"metadata": {"name": m.name, "data": dict(m.metadata)}}), file=out)
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            line = {
                "topic": channel.topic,
                "schema": schema.name,
                "log_time": message.log_time,
                "publish_time": message.publish_time,
                "sequence": message.sequence,
            }
            line.update(fields(schema.name, decoded))
            print(json.dumps(line, allow_nan=False), file=out)


if __name__ == "__main__":
    main()
