# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The DDS player delivers every message, in order, with /clock, to a live subscriber."""
from __future__ import annotations

import os
import threading

import numpy as np
import rclpy
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import PointCloud2

from fastslam_ros.tools.bags.bag_schema import write_schema_bag
from fastslam_ros.tools.bags.play import main as play_main
from fastslam_ros.tools.bags.play import play_bag
from fastslam_ros.tools.simulation.sim import SimConfig, simulate

RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
SPIN_LIMIT = 60.0
"""Upper bound (s) on waiting for deliveries; the test never asserts on time."""
DOMAIN_ID = 100 + os.getpid() % 100
"""A DDS domain of its own, so players and nodes of other processes are not heard."""


def test_player_delivers_every_message_with_clock(tmp_path):
    bag = simulate(SimConfig(duration=2.0, seed=1))
    path = write_schema_bag(tmp_path / "bag", bag)
    subscriber_context, player_context = Context(), Context()
    rclpy.init(context=subscriber_context, domain_id=DOMAIN_ID)
    rclpy.init(context=player_context, domain_id=DOMAIN_ID)
    received: dict[str, list] = {"/odom": [], "/landmarks": [], "/clock": []}
    node = rclpy.create_node("play_test_listener", context=subscriber_context)
    try:
        node.create_subscription(Odometry, "/odom", received["/odom"].append, RELIABLE)
        node.create_subscription(PointCloud2, "/landmarks", received["/landmarks"].append,
                                 RELIABLE)
        node.create_subscription(Clock, "/clock", received["/clock"].append, RELIABLE)
        executor = SingleThreadedExecutor(context=subscriber_context)
        executor.add_node(node)
        sent: list[int] = []
        player = threading.Thread(target=lambda: sent.append(play_bag(
            path, rate=4.0, topics=["/odom", "/landmarks"], wait_for_subscribers=SPIN_LIMIT,
            context=player_context)))
        player.start()
        expected = {"/odom": len(bag.odometry.stamps), "/landmarks": len(bag.scans.stamps)}
        final_stamp = bag.odometry.stamps[-1]

        def waiting() -> bool:
            clock = received["/clock"]
            last_clock = clock[-1].clock.sec + 1e-9 * clock[-1].clock.nanosec if clock else -1.0
            return (player.is_alive() or last_clock < final_stamp
                    or any(len(received[t]) < n for t, n in expected.items()))

        deadline = node.get_clock().now().nanoseconds + int(SPIN_LIMIT * 1e9)
        while waiting() and node.get_clock().now().nanoseconds < deadline:
            executor.spin_once(timeout_sec=0.05)
        player.join()
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=subscriber_context)
        rclpy.try_shutdown(context=player_context)

    assert sent == [expected["/odom"] + expected["/landmarks"]]
    odom_stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in received["/odom"]]
    np.testing.assert_allclose(odom_stamps, bag.odometry.stamps, atol=1e-9)
    assert len(received["/landmarks"]) == expected["/landmarks"]
    assert received["/landmarks"][3].width == len(bag.scans.ids[3])
    clock = np.array([m.clock.sec + 1e-9 * m.clock.nanosec for m in received["/clock"]])
    assert np.all(np.diff(clock) >= 0)
    assert clock[-1] == bag.odometry.stamps[-1]


def test_player_reports_a_missing_bag_or_topic(tmp_path, capsys):
    assert play_main([str(tmp_path / "absent")]) == 2  # a missing input is a usage error
    assert "not found" in capsys.readouterr().err
    path = write_schema_bag(tmp_path / "bag", simulate(SimConfig(duration=1.0)))
    assert play_main([str(path), "--topics", "/nothing"]) == 1
    assert "/nothing" in capsys.readouterr().err
