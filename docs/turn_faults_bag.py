# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A copy of a schema bag whose ``/odom`` reports turns the robot did not make.

MRCLAM's odometry integrates the commanded velocities, so a commanded turn the robot does not
make (a wheel stuck, a robot pushed) shows in the odometry and not in the motion. This writes
that regime onto a real recording: about one fault a minute (Poisson, from 30 s after the
start to 10 s before the end), each an extra turn of 0.3-0.8 rad either way spread over 1 s,
inserted into the odometry (every later odometry pose turns with it about the fault); every
other message is copied unchanged, the ground truth included. Usage:

    python3 docs/turn_faults_bag.py BAG OUT SEED
"""
import math
import sys
from pathlib import Path

import numpy as np
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.highlevel import AnyReader

from fastslam_ros.tools.bags.bag_schema import ODOM_TOPIC, TYPESTORE, open_writer

FAULTS_PER_MINUTE = 1.0
FAULT_DURATION = 1.0
"""Seconds over which a fault's extra turn builds up."""


def fault_schedule(start: float, end: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(times (s), extra turns (rad)) of the faults of a recording from ``start`` to ``end``."""
    rng = np.random.default_rng(seed)
    count = rng.poisson(FAULTS_PER_MINUTE * (end - start) / 60.0)
    times = np.sort(rng.uniform(start + 30.0, end - 10.0, count))
    return times, rng.choice([-1.0, 1.0], count) * rng.uniform(0.3, 0.8, count)


def write_faulty_copy(bag: Path, out: Path, seed: int) -> int:
    """Write the copy; returns the number of faults."""
    with AnyReader([bag], default_typestore=TYPESTORE) as reader:
        times, turns = fault_schedule(reader.start_time * 1e-9, reader.end_time * 1e-9, seed)
    previous = reported = None
    previous_extra = 0.0
    with AnyReader([bag], default_typestore=TYPESTORE) as reader, \
            open_writer(out, "mcap", inputs=[bag]) as writer:
        connections = {}
        for connection, stamp_ns, raw in reader.messages():
            if connection.topic not in connections:
                connections[connection.topic] = writer.add_connection(
                    connection.topic, connection.msgtype, typestore=TYPESTORE)
            if connection.topic == ODOM_TOPIC:
                msg = deserialize_message(bytes(raw), Odometry)
                pose = msg.pose.pose
                q = pose.orientation
                odometry = np.array([pose.position.x, pose.position.y,
                                     math.atan2(2 * (q.w * q.z + q.x * q.y),
                                                1 - 2 * (q.y * q.y + q.z * q.z))])
                stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
                extra = float(np.sum(turns * np.clip((stamp - times) / FAULT_DURATION, 0, 1)))
                if previous is None:
                    reported = odometry.copy()
                else:
                    # The odometry's own step, in its frame, applied to the reported pose.
                    c, s = math.cos(previous[2]), math.sin(previous[2])
                    dx, dy = odometry[:2] - previous[:2]
                    forward, left = c * dx + s * dy, -s * dx + c * dy
                    c, s = math.cos(reported[2]), math.sin(reported[2])
                    reported = reported + [c * forward - s * left, s * forward + c * left,
                                           odometry[2] - previous[2] + extra - previous_extra]
                previous, previous_extra = odometry, extra
                pose.position.x, pose.position.y = float(reported[0]), float(reported[1])
                q.x = q.y = 0.0
                q.z, q.w = math.sin(reported[2] / 2.0), math.cos(reported[2] / 2.0)
                raw = serialize_message(msg)
            writer.write(connections[connection.topic], stamp_ns, raw)
    return len(times)


if __name__ == "__main__":
    if len(sys.argv) != 4 or not sys.argv[3].isdigit():
        print("usage: turn_faults_bag.py BAG OUT SEED", file=sys.stderr)
        sys.exit(2)
    count = write_faulty_copy(Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3]))
    print(f"{sys.argv[2]}: {count} faults")
