# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Publish a rosbag2 folder over DDS with ``/clock``, for machines without ``ros2 bag play``.

Messages go out in bag-time order, paced by bag time divided by ``--rate``, each as its raw CDR
bytes (no conversion). ``/clock`` (``rosgraph_msgs/Clock``) carries the bag time before every
message and at ``--clock-rate`` in between, so a node started with ``use_sim_time:=true`` runs
on the bag's time::

    fastslam_node --ros-args -p use_sim_time:=true --params-file config/fastslam.yaml &
    fastslam-play sim_loop --rate 2

Publishers are RELIABLE and keep the last 1,000 messages, so a reliable subscriber that is
matched late in discovery still receives everything; a topic with a single message (the
landmark ground truth) is TRANSIENT_LOCAL, so late subscribers get it too.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Iterable

import rclpy
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.highlevel import AnyReader, AnyReaderError
from rosgraph_msgs.msg import Clock

from fastslam_ros.tools import cli
from fastslam_ros.tools.bags.bag_schema import TYPESTORE, ros_message_class

CLOCK_TOPIC = "/clock"
PUBLISHER_DEPTH = 1000


def _qos(latched: bool) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=1 if latched else PUBLISHER_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def play_bag(bag_path: str | Path, rate: float = 1.0, loop: bool = False,
             topics: Iterable[str] | None = None, clock_rate: float = 100.0,
             wait_for_subscribers: float = 0.0, context: Context | None = None) -> int:
    """Publish the bag (optionally only ``topics``) and return the number of messages sent.

    ``wait_for_subscribers`` > 0: before playing, wait up to that many seconds until every
    topic has a matched subscriber. ``context`` must be initialised (default: the global one).
    """
    if rate <= 0.0:
        raise ValueError("rate: must be > 0")
    bag_path = Path(bag_path)
    if not bag_path.exists():
        raise FileNotFoundError(f"bag not found: {bag_path}")
    wanted = set(topics) if topics else None
    node = rclpy.create_node("fastslam_bag_player", context=context)
    try:
        clock_publisher = node.create_publisher(Clock, CLOCK_TOPIC, _qos(False))
        with AnyReader([bag_path], default_typestore=TYPESTORE) as reader:
            connections = [c for c in reader.connections if wanted is None or c.topic in wanted]
            if wanted and (missing := wanted - {c.topic for c in connections}):
                raise ValueError(f"{bag_path} has no topic(s) {', '.join(sorted(missing))}")
            publishers = {}
            for connection in connections:
                if connection.topic not in publishers:
                    publishers[connection.topic] = node.create_publisher(
                        ros_message_class(connection.msgtype, connection.topic), connection.topic,
                        _qos(connection.msgcount == 1))
            _wait_for_subscribers(node, list(publishers.values()), wait_for_subscribers)
            sent = 0
            while True:
                sent += _play_once(reader, connections, publishers, clock_publisher, rate,
                                   clock_rate, context)
                if not loop or not rclpy.ok(context=context):
                    return sent
    finally:
        node.destroy_node()


DISCOVERY_SETTLE = 1.0
"""Seconds to wait after the publishers see their subscribers: discovery is two-sided, and a
reader that has not matched the writer yet drops what it sends (seen as lost first messages)."""


def _wait_for_subscribers(node, publishers: list, timeout: float) -> None:
    """Wait until every publisher has a subscriber (and discovery has settled), or time out."""
    deadline = time.monotonic() + timeout
    while timeout > 0.0 and time.monotonic() < deadline:
        if all(publisher.get_subscription_count() > 0 for publisher in publishers):
            time.sleep(DISCOVERY_SETTLE)
            return
        time.sleep(0.05)
    if timeout > 0.0:
        lonely = [p.topic_name for p in publishers if p.get_subscription_count() == 0]
        node.get_logger().warning(f"no subscriber after {timeout:g} s on: {', '.join(lonely)}")


def _play_once(reader: AnyReader, connections, publishers, clock_publisher, rate: float,
               clock_rate: float, context: Context | None) -> int:
    """One pass over the bag, paced by bag time; returns the messages published."""
    start_wall = time.monotonic()
    start_bag_ns: int | None = None
    clock_period = 1.0 / clock_rate if clock_rate > 0.0 else float("inf")
    sent = 0

    def publish_clock(bag_ns: int) -> None:
        message = Clock()
        message.clock.sec, message.clock.nanosec = divmod(bag_ns, 1_000_000_000)
        clock_publisher.publish(message)

    for connection, stamp_ns, raw in reader.messages(connections=connections):
        if not rclpy.ok(context=context):
            break
        if start_bag_ns is None:
            start_bag_ns = stamp_ns
        due = start_wall + (stamp_ns - start_bag_ns) * 1e-9 / rate
        while (remaining := due - time.monotonic()) > 0.0:
            time.sleep(min(remaining, clock_period))
            elapsed = min(time.monotonic(), due) - start_wall
            publish_clock(start_bag_ns + int(elapsed * rate * 1e9))
        publish_clock(stamp_ns)
        publishers[connection.topic].publish(bytes(raw))
        sent += 1
    return sent


def main(argv: list[str] | None = None) -> int:
    """``fastslam-play``: publish a bag over DDS with /clock."""
    parser = cli.parser("fastslam-play", __doc__)
    parser.add_argument("bag", type=Path, help="rosbag2 folder (mcap or sqlite3)")
    parser.add_argument("--rate", type=cli.positive(float), default=1.0,
                        help="playback speed factor")
    parser.add_argument("--loop", action="store_true", help="start over at the end, until Ctrl-C")
    parser.add_argument("--topics", nargs="+", default=None,
                        help="only these topics (default: all)")
    parser.add_argument("--clock-rate", type=float, default=100.0,
                        help="/clock messages per second of wall time between messages")
    parser.add_argument("--wait-for-subscribers", type=float, default=0.0, metavar="SECONDS",
                        help="first wait up to this long for a subscriber on every topic")
    args = parser.parse_args(argv)
    try:
        cli.input_bag(args.bag)
    except cli.UsageError as error:
        return cli.fail("fastslam-play", error)
    context = Context()
    rclpy.init(args=None, context=context)
    try:
        sent = play_bag(args.bag, args.rate, args.loop, args.topics, args.clock_rate,
                        args.wait_for_subscribers, context)
        print(f"published {sent} messages from {args.bag}", file=sys.stderr)
        return 0
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    except (FileNotFoundError, ValueError, OSError, AnyReaderError) as error:
        return cli.fail("fastslam-play", error)
    finally:
        rclpy.try_shutdown(context=context)


if __name__ == "__main__":
    sys.exit(main())
