# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""``fastslam-poison BAG --out OUT``: a copy of a schema-v1 bag with bad input mixed in.

Every valid message is kept; about ``--rate`` faults per second of data are added, drawn in
turn from every class the node must survive. Extra messages: glitched odometry (1e308, +1e6 m,
+100 m, a half turn, NaN, a zero quaternion, a wrong frame), stray and invalid stamps (1 h
ahead or behind, nanosec 2^32-1, negative seconds), byte-swapped (denormal), malformed and
oversized clouds. Added to a valid cloud: points at 1e-12 m, denormal, NaN or beyond range.
A bag with ``/scan`` (a people bag, a laser bag) takes malformed scans too: angles that do
not match the beams, NaN or crossed range limits, a NaN time increment, more beams than a node
reads, a wrong frame, stray and invalid stamps; one with ``/map`` unusable maps (resolution 0
or NaN, no known cell, data of the wrong size, a wrong frame), one with ``/initialpose``
initial poses off the map, NaN or with an absurd covariance. The node should drop exactly the
bad input, so replaying OUT gives the estimate of BAG (compare them with ``fastslam-eval``).
"""
from __future__ import annotations

import math
import sys
from functools import partial
from pathlib import Path
from typing import Callable

import numpy as np
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import LaserScan, PointCloud2
from std_msgs.msg import Header

from fastslam_ros import ros_io
from fastslam_ros.tools import cli
from fastslam_ros.tools.bags.bag_schema import (INITIAL_POSE_TOPIC, LANDMARKS_TOPIC, MAP_TOPIC,
                                                ODOM_TOPIC, SCAN_TOPIC, TOPIC_TYPES, TYPESTORE,
                                                SchemaError, bag_topics, check_topic_types,
                                                open_writer)

OVERSIZED_BEAMS = 10_000
"""Beams of the oversized scan (over the span of the scan it copies): more than any node reads
(``max_beams_per_scan``: 2048 for the people tracker, 8192 for the landmark extractor)."""
MESSAGE_CLASSES = {ODOM_TOPIC: Odometry, LANDMARKS_TOPIC: PointCloud2, SCAN_TOPIC: LaserScan,
                   MAP_TOPIC: OccupancyGrid, INITIAL_POSE_TOPIC: PoseWithCovarianceStamped}
"""The topics whose messages faults are made from, and their classes."""
SENSOR_TOPICS = (LANDMARKS_TOPIC, SCAN_TOPIC)


def _odometry(stamp: float, pose, frame: str, child: str) -> Odometry:
    msg = Odometry(header=Header(stamp=ros_io.seconds_to_stamp(stamp), frame_id=frame),
                   child_frame_id=child)
    msg.pose.pose = ros_io.pose_msg(pose)
    return msg


def _cloud(stamp: float, points, frame: str) -> PointCloud2:
    return ros_io.landmark_cloud(Header(stamp=ros_io.seconds_to_stamp(stamp), frame_id=frame),
                                 np.asarray(points, float))


def _shifted(msg, seconds: float):
    msg.header.stamp = ros_io.seconds_to_stamp(ros_io.stamp_to_seconds(msg.header.stamp)
                                               + seconds)
    return msg


def _with(msg, **changes):
    for name, value in changes.items():
        target = msg
        *parents, attribute = name.split("__")
        for parent in parents:
            target = getattr(target, parent)
        setattr(target, attribute, value)
    return msg


def _copy(stamp: float, last):
    """A copy of the message ``last`` stamped ``stamp`` (one a node would use)."""
    msg = deserialize_message(serialize_message(last), type(last))
    msg.header.stamp = ros_io.seconds_to_stamp(stamp)
    return msg


def odometry_faults() -> list[tuple[str, Callable]]:
    """(name, build(stamp, last messages by topic) -> (topic, message)) of odometry."""
    def odom(change):
        def build(stamp, last):
            last_odom = last[ODOM_TOPIC]
            p = last_odom.pose.pose
            pose = np.array([p.position.x, p.position.y, ros_io.quaternion_to_yaw(p.orientation)])
            return ODOM_TOPIC, change(_odometry(stamp, pose, last_odom.header.frame_id,
                                                last_odom.child_frame_id), pose)
        return build

    def jumped(offset):
        return odom(lambda m, pose: _odometry(ros_io.stamp_to_seconds(m.header.stamp),
                                              pose + offset, m.header.frame_id, m.child_frame_id))

    return [
        ("odometry 1e308", jumped(np.array([1e308, 0.0, 0.0]))),
        ("odometry +1e6 m", jumped(np.array([1e6, 0.0, 0.0]))),
        ("odometry +100 m", jumped(np.array([100.0, 0.0, 0.0]))),
        ("odometry half turn", jumped(np.array([0.0, 0.0, 3.0]))),
        ("odometry NaN", odom(lambda m, _p: _with(m, pose__pose__position__x=math.nan))),
        ("odometry zero quaternion", odom(lambda m, _p: _with(
            m, pose__pose__orientation__z=0.0, pose__pose__orientation__w=0.0))),
        ("odometry 1 h ahead", odom(lambda m, _p: _shifted(m, 3600.0))),
        ("odometry 1 h behind", odom(lambda m, _p: _shifted(m, -3600.0))),
        ("odometry nanosec 2^32-1", odom(lambda m, _p: _with(m, header__stamp__nanosec=2**32 - 1))),
        ("odometry wrong frame", odom(lambda m, _p: _with(m, header__frame_id="world"))),
    ]


def _changed_copy(topic: str, change: Callable) -> Callable:
    """build(stamp, last messages by topic) -> (topic, ``change`` of a copy of the last
    message on ``topic``, stamped ``stamp``)."""
    def build(stamp, last):
        return topic, change(_copy(stamp, last[topic]))
    return build


def scan_faults() -> list[tuple[str, Callable]]:
    """(name, build(stamp, last messages by topic) -> (topic, message)) of laser scans."""
    scan = partial(_changed_copy, SCAN_TOPIC)

    def beams_off(count):
        return scan(lambda m: _with(m, angle_max=m.angle_max + count * m.angle_increment))

    def oversized(m):
        increment = m.angle_increment * (len(m.ranges) - 1) / (OVERSIZED_BEAMS - 1)
        return _with(m, ranges=[1.0] * OVERSIZED_BEAMS, intensities=[],
                     angle_increment=increment,
                     angle_max=m.angle_min + (OVERSIZED_BEAMS - 1) * increment)

    return [
        ("scan angle_max 3 beams off", beams_off(3)),
        ("scan angle_max 1 beam short", beams_off(-1)),
        ("scan range_max < range_min", scan(lambda m: _with(m, range_min=5.0, range_max=1.0))),
        ("scan range_min NaN", scan(lambda m: _with(m, range_min=math.nan))),
        ("scan time_increment NaN", scan(lambda m: _with(m, time_increment=math.nan))),
        (f"scan of {OVERSIZED_BEAMS} beams", scan(oversized)),
        ("scan 1 h ahead", scan(lambda m: _shifted(m, 3600.0))),
        ("scan negative sec", scan(lambda m: _with(m, header__stamp__sec=-3))),
        ("scan wrong frame", scan(lambda m: _with(m, header__frame_id="world"))),
    ]


def map_faults() -> list[tuple[str, Callable]]:
    """(name, build(stamp, last messages by topic) -> (topic, message)) of occupancy grids."""
    grid = partial(_changed_copy, MAP_TOPIC)

    return [
        ("map resolution 0", grid(lambda m: _with(m, info__resolution=0.0))),
        ("map resolution NaN", grid(lambda m: _with(m, info__resolution=math.nan))),
        ("map of unknown cells", grid(lambda m: _with(m, data=[-1] * len(m.data)))),
        ("map data short", grid(lambda m: _with(m, data=list(m.data)[:-1]))),
        ("map wrong frame", grid(lambda m: _with(m, header__frame_id="world"))),
    ]


def initial_pose_faults() -> list[tuple[str, Callable]]:
    """(name, build(stamp, last messages by topic) -> (topic, message)) of initial poses."""
    pose = partial(_changed_copy, INITIAL_POSE_TOPIC)

    return [
        ("initialpose 1000 m off", pose(lambda m: _with(
            m, pose__pose__position__x=m.pose.pose.position.x + 1e3))),
        ("initialpose NaN", pose(lambda m: _with(m, pose__pose__position__y=math.nan))),
        ("initialpose covariance 1e300", pose(lambda m: _with(
            m, pose__covariance=[1e300 if i in (0, 7, 35) else 0.0 for i in range(36)]))),
    ]


def cloud_faults(rng: np.random.Generator) -> list[tuple[str, Callable]]:
    """(name, build(stamp, last messages by topic) -> (topic, message)) of landmark clouds;
    a build with ``amends`` instead changes the next valid cloud (build(msg) -> msg)."""
    def cloud(points_of):
        def build(stamp, last):
            last_cloud = last[LANDMARKS_TOPIC]
            good = ros_io.read_landmark_cloud(last_cloud)
            points = points_of(np.column_stack([good.x, good.y]))
            return LANDMARKS_TOPIC, _cloud(stamp, points, last_cloud.header.frame_id)
        return build

    def cloud_msg(change):
        def build(stamp, last):
            return LANDMARKS_TOPIC, change(cloud(lambda p: p)(stamp, last)[1])
        return build

    def byte_swapped(points):
        # Little-endian floats whose two low bytes are zero, declared big-endian: denormals.
        bits = np.asarray(points, np.float32).view(np.uint32) & np.uint32(0xFFFF0000)
        return bits.view(np.float32).astype(float)

    def swapped_cloud(stamp, last):
        topic, msg = cloud(byte_swapped)(stamp, last)
        msg.is_bigendian = True
        return topic, msg

    def amend(extra):
        """Bad points added to the next valid cloud (marked: the caller amends, not inserts)."""
        def build(msg):
            good = ros_io.read_landmark_cloud(msg)
            points = np.vstack([np.column_stack([good.x, good.y]), extra])
            ids = np.append(good.ids, np.full(len(extra), -1)) if good.ids is not None else None
            return ros_io.landmark_cloud(msg.header, points, ids)
        build.amends = True
        return build

    return [
        ("point at 1e-12 m", amend([[1e-12, 0.0]])),
        ("denormal point", amend([[1e-40, 1e-41]])),
        ("NaN point", amend([[math.nan, 1.0]])),
        ("point beyond range", amend([[1e4, 0.0]])),
        ("cloud byte-swapped", swapped_cloud),
        ("cloud 1 h ahead", cloud_msg(lambda m: _shifted(m, 3600.0))),
        ("cloud negative sec", cloud_msg(lambda m: _with(m, header__stamp__sec=-3))),
        ("cloud of 1e4 points", cloud(lambda p: rng.uniform(-30.0, 30.0, (10_000, 2)))),
        ("cloud without y", cloud_msg(lambda m: _with(
            m, fields=[f for f in m.fields if f.name != "y"]))),
        ("cloud short data", cloud_msg(lambda m: _with(m, data=bytes(m.data)[:-3]))),
        ("cloud width 0 with data", cloud_msg(lambda m: _with(m, width=0))),
    ]


def fault_builders(rng: np.random.Generator, topics) -> list[tuple[str, Callable]]:
    """Every fault class of a bag with these input ``topics``: the odometry's, then those of
    the landmark clouds, scans, maps and initial poses it has."""
    present = {LANDMARKS_TOPIC: lambda: cloud_faults(rng), SCAN_TOPIC: scan_faults,
               MAP_TOPIC: map_faults, INITIAL_POSE_TOPIC: initial_pose_faults}
    return odometry_faults() + [fault for topic, faults in present.items() if topic in topics
                                for fault in faults()]


def _decoded(raw: bytes | memoryview, cls: type) -> object | None:
    """The message, or None for bytes that do not decode (copied as they are, never a
    template)."""
    try:
        return deserialize_message(bytes(raw), cls)
    except Exception:  # noqa: BLE001 - whatever the middleware raises on bad bytes
        return None


def poison_bag(bag: str | Path, out: str | Path, rate: float = 1.0, seed: int = 0,
               overwrite: bool = False) -> dict[str, int]:
    """Write OUT: BAG's messages plus ``rate`` bad ones per second; returns the count by class."""
    rng = np.random.default_rng(seed)
    topics = bag_topics(bag)  # a bag with the inputs, of their types, before any output
    inputs = tuple(topic for topic in MESSAGE_CLASSES if topic in topics)
    if ODOM_TOPIC not in inputs or not set(SENSOR_TOPICS) & set(inputs):
        raise SchemaError(f"{bag}: missing topic(s): {ODOM_TOPIC} and {LANDMARKS_TOPIC} or "
                          f"{SCAN_TOPIC}")
    check_topic_types(topics, bag, inputs)
    builders = fault_builders(rng, inputs)
    counts = dict.fromkeys((name for name, _ in builders), 0)
    with AnyReader([Path(bag)], default_typestore=TYPESTORE) as reader, \
            open_writer(out, "mcap", overwrite, inputs=[bag]) as writer:
        connections = {}
        last: dict[str, object] = {}
        next_fault, turn, amend = None, 0, None
        for connection, stamp_ns, raw in reader.messages():
            if connection.topic not in connections:
                connections[connection.topic] = writer.add_connection(
                    connection.topic, connection.msgtype, typestore=TYPESTORE)
            msg = _decoded(raw, MESSAGE_CLASSES[connection.topic]) \
                if connection.topic in inputs else None
            if amend is not None and msg is not None and connection.topic == LANDMARKS_TOPIC:
                raw = serialize_message(amend(msg))
                amend = None
            writer.write(connections[connection.topic], stamp_ns, raw)
            if msg is not None:
                last[connection.topic] = msg
            stamp = stamp_ns * 1e-9
            next_fault = stamp + rng.exponential(1.0 / rate) if next_fault is None else next_fault
            if stamp < next_fault or len(last) < len(inputs):
                continue
            name, build = builders[turn % len(builders)]
            turn += 1
            counts[name] += 1
            next_fault = stamp + rng.exponential(1.0 / rate)
            if getattr(build, "amends", False):
                amend = build
                continue
            # Between this message and the next odometry: half an odometry period later.
            topic, msg = build(stamp + 0.0125, last)
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, TOPIC_TYPES[topic],
                                                           typestore=TYPESTORE)
            writer.write(connections[topic], stamp_ns + 1, serialize_message(msg))
    return counts


@cli.interruptible("fastslam-poison")
def main(argv: list[str] | None = None) -> int:
    """``fastslam-poison``: write a copy of a bag with every fault class mixed in."""
    prog = "fastslam-poison"
    parser = cli.parser(prog, __doc__, first_paragraph=True)
    parser.add_argument("bag", type=Path, help="schema-v1 bag")
    parser.add_argument("--out", type=Path, required=True, help="output bag folder")
    parser.add_argument("--rate", type=cli.positive(float), default=1.0,
                        help="bad messages per second of data")
    parser.add_argument("--seed", type=int, default=0, help="seed of the faults' draws")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing output bag (never another folder or the input)")
    args = parser.parse_args(argv)
    try:
        cli.input_bag(args.bag)
        cli.output_folder(args.out, "--out")
    except cli.UsageError as error:
        return cli.fail(prog, error)
    try:
        counts = poison_bag(args.bag, args.out, args.rate, args.seed, args.overwrite)
    except (OSError, ValueError) as error:
        return cli.fail(prog, error, cli.EXIT_FAILURE)
    print(f"wrote {args.out}: {sum(counts.values())} bad messages added "
          f"({', '.join(f'{name} {count}' for name, count in counts.items())})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
