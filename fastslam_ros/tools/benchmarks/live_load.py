# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Live load test over DDS: a ``fastslam_node`` process fed by this one at chosen rates.

Starts ``fastslam_node`` in a child process on a private domain id, publishes odometry of a
robot driving a circle and landmark clouds (eight landmarks with ids) at ``--odom-rate`` and
``--cloud-rate`` for ``--seconds``, and reads ``/diagnostics``. Three phases: the given rates
(is anything lost?), the same with ten odometry messages deliberately withheld (how long until
``/diagnostics`` WARNs about the gap?), and ``--burst-rate`` odometry (is the loss visible?).
Prints figures; no asserts.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header

from fastslam_ros import ros_io
from fastslam_ros.tools import cli

LANDMARKS = np.array([[6.0, 0.0], [4.0, 5.0], [-2.0, 6.0], [-6.0, 1.0], [-4.0, -5.0],
                      [2.0, -6.0], [8.0, -3.0], [7.0, 5.0]])


def robot_pose(t: float) -> np.ndarray:
    """A circle of 3 m radius at 0.5 m/s."""
    angle = 0.5 / 3.0 * t
    return np.array([3.0 * math.sin(angle), 3.0 - 3.0 * math.cos(angle),
                     math.atan2(math.sin(angle), math.cos(angle))])


def sensor_points(pose: np.ndarray) -> np.ndarray:
    """The landmarks in view of ``pose``, in the sensor frame."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    d = LANDMARKS - pose[:2]
    return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])


class Driver:
    """Publishes the inputs and keeps the node's diagnostics."""

    def __init__(self, context: Context) -> None:
        self.node = rclpy.create_node("fastslam_load_driver", context=context)
        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        self.odom = self.node.create_publisher(Odometry, "/odom", qos)
        self.clouds = self.node.create_publisher(PointCloud2, "/landmarks", qos)
        self.diagnostics: list[tuple[float, DiagnosticStatus]] = []
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 50)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.start = time.monotonic()
        self.sent = {"odom": 0, "landmarks": 0}

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            self.diagnostics.append((time.monotonic(), status))

    def spin_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)

    def wait_for_node(self, timeout: float = 30.0) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.odom.get_subscription_count() and self.clouds.get_subscription_count():
                self.spin_for(1.0)  # discovery is two-sided: let the reader match too
                return True
            self.spin_for(0.1)
        return False

    def counters(self) -> dict[str, str]:
        """The newest counters the node reported."""
        return {kv.key: kv.value for kv in self.diagnostics[-1][1].values} \
            if self.diagnostics else {}

    def drive(self, seconds: float, odom_rate: float, cloud_rate: float,
              withhold: tuple[float, int] | None = None) -> float | None:
        """Publish for ``seconds``; with ``withhold`` (at s, count) skip that many odometry
        messages and return the wall time of the skip."""
        begin = time.monotonic()
        next_odom = next_cloud = begin
        skipped_at, to_skip = None, 0
        while (now := time.monotonic()) < begin + seconds:
            if now >= next_odom:
                t = now - self.start
                if withhold and skipped_at is None and now - begin >= withhold[0]:
                    skipped_at, to_skip = now, withhold[1]
                if to_skip:
                    to_skip -= 1
                else:
                    msg = Odometry(header=Header(stamp=ros_io.seconds_to_stamp(t),
                                                 frame_id="odom"), child_frame_id="base_link")
                    msg.pose.pose = ros_io.pose_msg(robot_pose(t))
                    self.odom.publish(msg)
                    self.sent["odom"] += 1
                next_odom += 1.0 / odom_rate
            if now >= next_cloud:
                t = now - self.start
                self.clouds.publish(ros_io.landmark_cloud(
                    Header(stamp=ros_io.seconds_to_stamp(t), frame_id="base_link"),
                    sensor_points(robot_pose(t)), np.arange(len(LANDMARKS))))
                self.sent["landmarks"] += 1
                next_cloud += 1.0 / cloud_rate
            self.executor.spin_once(timeout_sec=max(0.0, min(next_odom, next_cloud)
                                                     - time.monotonic()))
        return skipped_at

    def first_warning_after(self, since: float, words: str) -> float | None:
        for stamp, status in self.diagnostics:
            if stamp >= since and status.level == DiagnosticStatus.WARN and words in status.message:
                return stamp - since
        return None


def run_phase(context: Context, args, odom_rate: float,
              withhold: tuple[float, int] | None):
    """One phase against a fresh node process: (sent, the node's final counters, seconds from
    the start (or the withheld messages) to the first WARN about lost messages)."""
    env = {**os.environ, "ROS_DOMAIN_ID": str(args.domain)}
    node_process = subprocess.Popen(
        [sys.executable, "-m", "fastslam_ros.node", "--ros-args", "-p",
         f"num_particles:={args.particles}", "-p", "seed:=1", "-p", "association:=known",
         "-p", "sigma_range:=0.05"], env=env, stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL)
    driver = Driver(context)
    try:
        if not driver.wait_for_node():
            raise RuntimeError("the node did not come up")
        begin = time.monotonic()
        skipped_at = driver.drive(args.seconds, odom_rate, args.cloud_rate, withhold)
        driver.spin_for(2.5)  # the last messages in, two more diagnostics periods
        since = skipped_at if skipped_at is not None else begin
        return dict(driver.sent), driver.counters(), driver.first_warning_after(since, "lost")
    finally:
        driver.node.destroy_node()
        node_process.terminate()
        node_process.wait(timeout=10)


def main(argv: list[str] | None = None) -> int:
    """``python3 -m fastslam_ros.tools.benchmarks.live_load``: the live DDS load test."""
    parser = cli.parser("python3 -m fastslam_ros.tools.benchmarks.live_load", __doc__,
                        first_paragraph=True)
    parser.add_argument("--odom-rate", type=float, default=100.0,
                        help="odometry rate of the first two phases (Hz)")
    parser.add_argument("--cloud-rate", type=float, default=20.0, help="landmark cloud rate (Hz)")
    parser.add_argument("--burst-rate", type=float, default=1000.0,
                        help="odometry rate of the last phase (Hz)")
    parser.add_argument("--seconds", type=float, default=10.0, help="length of each phase (s)")
    parser.add_argument("--particles", type=int, default=100, help="number of particles M")
    parser.add_argument("--domain", type=int, default=None,
                        help="ROS domain id of the test (default: 90 + pid %% 100)")
    args = parser.parse_args(argv)
    if args.domain is None:
        args.domain = 90 + os.getpid() % 100
    context = Context()
    rclpy.init(context=context, domain_id=args.domain)
    phases = []
    try:
        for name, odom_rate, withhold in (
                (f"{args.odom_rate:g} Hz odometry + {args.cloud_rate:g} Hz clouds",
                 args.odom_rate, None),
                ("same, 10 odometry messages withheld at 3 s", args.odom_rate, (3.0, 10)),
                (f"{args.burst_rate:g} Hz odometry + {args.cloud_rate:g} Hz clouds",
                 args.burst_rate, None)):
            phases.append((name, *run_phase(context, args, odom_rate, withhold)))
    except RuntimeError as error:
        print(f"live_load: {error}", file=sys.stderr)
        return 1
    finally:
        rclpy.try_shutdown(context=context)
    print("| phase | odometry sent / received / reported lost | clouds sent / received | "
          "WARN 'lost' after (s) |")
    print("|---|---|---|---|")
    for name, sent, got, warned in phases:
        print(f"| {name} | {sent['odom']} / {got.get('received_odom')} / "
              f"{got.get('odom_missing')} | {sent['landmarks']} / "
              f"{got.get('received_landmarks')} | {'-' if warned is None else f'{warned:.2f}'} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
