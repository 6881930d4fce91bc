# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""FastSLAMNode with real rclpy: scripted runs through the callbacks and over DDS.

Every test has its own Context on a domain id of its own process, so parallel test runs on the
machine do not see each other's topics. Most tests call the subscription callbacks directly and
drive a simulated node clock, as a bag replay does: they are deterministic. The DDS tests wait
for messages with bounded spin loops and assert on content, never on timing.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as PathMsg
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header
from std_srvs.srv import Trigger
from visualization_msgs.msg import Marker, MarkerArray

from fastslam_ros import ros_io, ros_markers
from fastslam_ros.node_support.timing import OdometryHistory, interpolate_pose
from fastslam_ros.node import CORE_PARAMETERS, NODE_PARAMETERS, FastSLAMNode, ParameterError
from fastslam_ros.tools.bags import cdr
from fastslam_ros.tools.bags.in_process import in_process

REPO = Path(__file__).resolve().parents[1]
DOMAIN_ID = 100 + os.getpid() % 100
START = 100.0
"""Stamp (s) of the first odometry of a scripted run."""
LANDMARKS = np.array([[3.0, 0.0], [2.0, 3.0], [-1.0, 3.5], [-3.0, 1.0], [-2.0, -2.5],
                      [1.0, -3.0], [4.5, -2.0], [5.0, 2.5]])
LANDMARK_IDS = np.arange(10, 10 + len(LANDMARKS))
ODOM_PERIOD = 0.05
CLOUD_PERIOD = 0.2
CLOUD_PHASE = 0.013
"""Clouds are stamped between odometry stamps, so their poses must be interpolated."""
CLOUD_LATENCY = 0.03
"""Clouds arrive this long after their stamp (after the odometry that covers them)."""
BASE_PARAMETERS = {"seed": 1, "num_particles": 40, "sigma_range": 0.05, "use_sim_time": True}
POSITION_TOLERANCE = 0.15
"""m: the estimate of a noise-free scripted run stays this close to the truth."""
YAW_TOLERANCE = 0.05
"""rad: same for the heading."""
SPIN_LIMIT = 10.0
"""s of wall time a DDS wait may take before the test fails (never reached when things work)."""


def truth_pose(t: float) -> np.ndarray:
    """Robot pose at ``t`` s after START: a unicycle arc at 0.4 m/s, 0.25 rad/s."""
    x0, y0, theta0, speed, turn = 0.5, -0.5, 0.3, 0.4, 0.25
    theta = theta0 + turn * t
    return np.array([x0 + speed / turn * (math.sin(theta) - math.sin(theta0)),
                     y0 - speed / turn * (math.cos(theta) - math.cos(theta0)),
                     math.atan2(math.sin(theta), math.cos(theta))])


def odometry(stamp: float, pose, frame: str = "odom") -> Odometry:
    msg = Odometry(header=Header(stamp=ros_io.seconds_to_stamp(stamp), frame_id=frame),
                   child_frame_id="base_link")
    msg.pose.pose = ros_io.pose_msg(pose)
    return msg


def sensor_points(pose: np.ndarray) -> np.ndarray:
    """Landmarks in the frame of a sensor at ``pose`` (sensor offset zero)."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    d = LANDMARKS - pose[:2]
    return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])


def cloud(stamp: float, points, ids=None, frame: str = "laser") -> PointCloud2:
    return ros_io.landmark_cloud(Header(stamp=ros_io.seconds_to_stamp(stamp), frame_id=frame),
                                 np.asarray(points, float), ids)


def truth_cloud(stamp: float, with_ids: bool = True) -> PointCloud2:
    return cloud(stamp, sensor_points(truth_pose(stamp - START)),
                 LANDMARK_IDS if with_ids else None)


@dataclass
class Event:
    """A message of a scripted run and the node-clock time at which it arrives."""

    arrival: float
    msg: object


def scripted_run(duration: float, begin: float = 0.0) -> list[Event]:
    """Noise-free odometry (20 Hz) and landmark clouds (5 Hz, stamped between odometry stamps,
    arriving CLOUD_LATENCY late) over ``[begin, begin + duration)`` s after START."""
    events = [Event(START + t, odometry(START + t, truth_pose(t)))
              for t in np.arange(begin, begin + duration, ODOM_PERIOD)]
    events += [Event(START + t + CLOUD_LATENCY, truth_cloud(START + t))
               for t in np.arange(begin + CLOUD_PHASE, begin + duration - 0.1, CLOUD_PERIOD)]
    return sorted(events, key=lambda e: e.arrival)


def set_clock(node: FastSLAMNode, seconds: float) -> None:
    node.get_clock().set_ros_time_override(Time(nanoseconds=round(seconds * 1e9)))


def deliver(node: FastSLAMNode, msg, arrival: float | None = None) -> None:
    """Call the node's callback as a replay does (clock first when given)."""
    if arrival is not None:
        set_clock(node, arrival)
    (node.on_odometry if isinstance(msg, Odometry) else node.on_landmarks)(msg)


def replay(node: FastSLAMNode, events: list[Event]) -> None:
    for event in events:
        deliver(node, event.msg, event.arrival)


class Recorder:
    """Output listener keeping every published message by topic."""

    def __init__(self, node: FastSLAMNode) -> None:
        self.messages: dict[str, list] = {}
        node.output_listeners.append(self)

    def __call__(self, topic: str, msg) -> None:
        self.messages.setdefault(topic, []).append(msg)

    def last(self, topic: str):
        return self.messages[topic][-1]

    def count(self, topic: str) -> int:
        return len(self.messages.get(topic, []))


CREATED_NODES: list[FastSLAMNode] = []
"""Nodes of the running test: destroyed before their context shuts down, never left to the
garbage collector (a Fast DDS participant torn down during a later collection can hang)."""


@pytest.fixture
def context():
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID)
    try:
        yield ctx
    finally:
        while CREATED_NODES:
            CREATED_NODES.pop().destroy_node()
        rclpy.shutdown(context=ctx)


def make_node(context: Context, live: bool = False, lean: bool = False,
              **parameters) -> FastSLAMNode:
    """The node driven in-process (outputs to listeners; ``lean``: look-alikes, as a replay's),
    or a ``live`` one, publishing over DDS."""
    values = {**BASE_PARAMETERS, **parameters}
    node_class = FastSLAMNode if live else in_process(FastSLAMNode, lean)
    node = node_class(context=context, parameter_overrides=[
        Parameter(name, value=value) for name, value in values.items()])
    CREATED_NODES.append(node)
    return node


def pose_error(pose_msg, stamp: float) -> tuple[float, float]:
    """Position (m) and heading (rad) error of a Pose against the truth at ``stamp``."""
    truth = truth_pose(stamp - START)
    position = pose_msg.position
    yaw = ros_io.quaternion_to_yaw(pose_msg.orientation)
    return (math.hypot(position.x - truth[0], position.y - truth[1]),
            abs(math.atan2(math.sin(yaw - truth[2]), math.cos(yaw - truth[2]))))


def ellipse_count(markers: MarkerArray) -> int:
    return sum(m.type == Marker.CYLINDER and m.action == Marker.ADD for m in markers.markers)


# --- time alignment (pure) ---------------------------------------------------------------------

def test_interpolate_pose_takes_the_short_way_round():
    pose = interpolate_pose(1.0, np.array([0.0, 0.0, 3.0]), 2.0, np.array([2.0, -4.0, -3.0]), 1.25)
    np.testing.assert_allclose(pose[:2], [0.5, -1.0])
    # From 3.0 to -3.0 rad is +0.283 rad across pi, not -6 rad.
    assert pose[2] == pytest.approx(3.0 + 0.25 * (2 * math.pi - 6.0))


def test_odometry_history_gives_consecutive_steps_ending_at_the_stamp():
    history = OdometryHistory()
    for stamp in (0.0, 0.1, 0.2, 0.3):
        history.append(stamp, np.array([10 * stamp, 0.0, 0.0]))
    assert history.covers(0.3) and not history.covers(0.31)
    steps = history.advance(0.25)
    np.testing.assert_allclose([step[1][0] for step in steps], [1.0, 2.0, 2.5])
    np.testing.assert_allclose(steps[0][0], [0.0, 0.0, 0.0])
    assert all(a is b for (_, b), (a, _) in zip(steps, steps[1:]))  # each starts where one ended
    assert history.anchor_stamp == 0.25 and history.advance(0.2) == []


# --- scripted runs through the callbacks --------------------------------------------------------

def test_lean_outputs_are_look_alikes_of_the_live_messages(context):
    """A replay's node (``in_process(..., lean=True)``) hands ~/particles over as the array of
    the PoseArray a live node publishes, ~/landmarks, ~/pose, ~/map_to_odom and ~/path as
    look-alikes of its messages."""
    runs = {}
    for dds in (True, False):  # True: the messages of the live node
        node = make_node(context, lean=not dds)
        outputs = Recorder(node)
        replay(node, scripted_run(3.0))
        runs[dds] = outputs.messages
    particles = runs[True]["/fastslam/particles"]
    assert particles and len(particles) == len(runs[False]["/fastslam/particles"])
    for live, planar in zip(particles, runs[False]["/fastslam/particles"]):
        assert isinstance(live, PoseArray) and isinstance(planar, ros_io.PlanarPoseArray)
        assert ros_io.pose_array(planar.header, planar.planar) == live
    markers = runs[True]["/fastslam/landmarks"]
    assert markers and len(markers) == len(runs[False]["/fastslam/landmarks"])
    for live, lean in zip(markers, runs[False]["/fastslam/landmarks"]):
        assert isinstance(live, MarkerArray) and isinstance(lean, ros_markers.MarkerArrayView)
        assert len(live.markers) == len(lean.markers)
    for topic, live_type, view_type, write in (
            ("/fastslam/pose", PoseWithCovarianceStamped, ros_io.PoseWithCovarianceStampedView,
             cdr.pose_with_covariance_stamped_cdr),
            ("/fastslam/map_to_odom", TransformStamped, ros_io.TransformStampedView,
             cdr.transform_stamped_cdr),
            ("/fastslam/path", PathMsg, ros_io.PathView, cdr.SequenceCdr(
                "poses", cdr.pose_stamped_piece, has_header=True).serialize)):
        lives, views = runs[True][topic], runs[False][topic]
        assert lives and len(lives) == len(views)
        for live, view in zip(lives, views):  # the writer's bytes are rclpy's (test_cdr)
            assert type(live) is live_type and type(view) is view_type
            assert write(view) == write(live)


def test_node_time_set_directly_gives_the_outputs_of_the_clock(context):
    """``set_node_time`` (what a replay calls) drives the throttled outputs, the stamps and
    /diagnostics exactly as the rclpy clock does."""
    runs = []
    for direct in (False, True):
        node = make_node(context)
        outputs = Recorder(node)
        for event in scripted_run(6.0):
            if direct:
                node.set_node_time(round(event.arrival * 1e9))
            else:
                set_clock(node, event.arrival)
            deliver(node, event.msg)
        node.flush()
        runs.append(outputs.messages)
    clock, direct = runs
    assert clock.keys() == direct.keys() and len(clock["/diagnostics"]) >= 6
    for topic, messages in clock.items():
        assert len(messages) == len(direct[topic]), topic
        for by_clock, by_time in zip(messages, direct[topic]):
            if topic == "/diagnostics":  # callback_time_max is wall time
                assert by_clock.header == by_time.header
                by_clock, by_time = ([(v.key, v.value) for v in msg.status[0].values
                                      if v.key != "callback_time_max"]
                                     for msg in (by_clock, by_time))
            assert by_clock == by_time, topic


def test_scripted_run_pose_map_and_throttled_outputs(context):
    node = make_node(context)
    outputs = Recorder(node)
    events = scripted_run(8.0)
    replay(node, events)
    node.flush()

    clouds = sum(isinstance(e.msg, PointCloud2) for e in events)
    assert node.stats["used_landmarks"] == clouds == outputs.count("/fastslam/pose")
    assert node.stats["observations_used"] == clouds * len(LANDMARKS)
    assert node.stats["late_observations"] == node.stats["stale_observations"] == 0
    assert not any(v for k, v in node.stats.items() if k.startswith("dropped_"))

    for pose in outputs.messages["/fastslam/pose"]:  # every pose of the run, not just the last
        errors = pose_error(pose.pose.pose, ros_io.stamp_to_seconds(pose.header.stamp))
        assert errors[0] < POSITION_TOLERANCE and errors[1] < YAW_TOLERANCE
    last_pose = outputs.last("/fastslam/pose")
    assert last_pose.header.frame_id == "map"
    covariance = np.array(last_pose.pose.covariance).reshape(6, 6)
    assert covariance[0, 0] > 0.0 and covariance[5, 5] > 0.0

    # Odometry equals the truth and the map frame starts at the first odometry pose, so
    # map -> odom stays near identity.
    transform = outputs.last("/fastslam/map_to_odom").transform
    assert math.hypot(transform.translation.x, transform.translation.y) < POSITION_TOLERANCE
    assert outputs.last("/fastslam/map_to_odom").child_frame_id == "odom"

    landmark_map = node.slam.best_map()
    assert len(landmark_map) == len(LANDMARKS)
    assert sorted(landmark_map.ids.tolist()) == LANDMARK_IDS.tolist()
    for mean, landmark_id in zip(landmark_map.means, landmark_map.ids):
        assert np.linalg.norm(mean - LANDMARKS[landmark_id - 10]) < POSITION_TOLERANCE
    assert ellipse_count(outputs.last("/fastslam/landmarks")) == len(LANDMARKS)
    assert outputs.last("/fastslam/map_cloud").width == len(LANDMARKS)
    assert node.stats["associations_checked"] == clouds * len(LANDMARKS)
    assert node.stats["associations_correct"] == node.stats["associations_checked"]

    # Heavy outputs follow their rates of node time (8 s of data), never every observation.
    assert 2 <= outputs.count("/fastslam/landmarks") <= 8 / 1.0 + 2 < clouds
    assert 2 <= outputs.count("/fastslam/particles") <= 8 * 2.0 + 2
    assert 2 <= outputs.count("/fastslam/path") <= 8 * 1.0 + 2
    assert len(outputs.last("/fastslam/path").poses) == clouds
    assert len(outputs.last("/fastslam/particles").poses) == 40
    diagnostics = outputs.last("/diagnostics").status[0]
    assert {kv.key: kv.value for kv in diagnostics.values}["used_landmarks"] == str(clouds)
    assert 7 <= outputs.count("/diagnostics") <= 8 + 2


def test_pose_estimate_mean_is_published_when_selected(context):
    node = make_node(context, pose_estimate="mean")
    outputs = Recorder(node)
    replay(node, scripted_run(2.0))
    mean, _ = node.slam.mean_pose_and_covariance()
    pose = outputs.last("/fastslam/pose").pose.pose
    assert (pose.position.x, pose.position.y) == pytest.approx((mean[0], mean[1]))


def test_with_smoothing_the_pose_and_map_are_the_smoothers(context):
    """``smoothing_period``: ~/pose is the smoother's pose (the truth within 0.1 m on the
    scripted run) and ~/map_cloud its solve's landmarks."""
    node = make_node(context, smoothing_period=1.0)
    outputs = Recorder(node)
    replay(node, scripted_run(6.0))
    assert node.stats["smoother_solves"] == node.slam.smoother.solves > 0
    assert node.stats["smoother_failures"] == 0
    message = outputs.last("/fastslam/pose")
    pose = message.pose.pose
    smoothed = node.slam.smoothed_pose()
    assert (pose.position.x, pose.position.y) == pytest.approx((smoothed[0], smoothed[1]))
    covariance = node.slam.smoothed_covariance()  # the solve's marginal, not the spread
    assert message.pose.covariance[0] == pytest.approx(covariance[0, 0])
    assert message.pose.covariance[35] == pytest.approx(covariance[2, 2])
    stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
    assert pose_error(pose, stamp)[0] < 0.1
    node._publish_map()
    assert outputs.last("/fastslam/map_cloud").width == len(node.slam.smoother.landmark_map)


def test_cloud_is_predicted_to_odometry_interpolated_at_its_stamp(context):
    node = make_node(context)
    calls = []  # ("predict", odometry pose predicted to) and ("update", None), in call order
    predict, update = node.slam.predict, node.slam.update
    node.slam.predict = lambda pose_from, pose_to: (calls.append(("predict", np.array(pose_to))),
                                                    predict(pose_from, pose_to))
    node.slam.update = lambda *args, **kwargs: (calls.append(("update", None)),
                                                update(*args, **kwargs))[1]
    for t in np.arange(0.0, 0.11, ODOM_PERIOD):
        deliver(node, odometry(START + t, truth_pose(t)), START + t)
    stamp = START + 0.13  # between the odometry at 0.10 and 0.15: it waits
    deliver(node, truth_cloud(stamp), START + 0.131)
    assert node.stats["used_landmarks"] == 0
    deliver(node, odometry(START + 0.15, truth_pose(0.15)), START + 0.15)
    assert node.stats["used_landmarks"] == 1
    kinds = [kind for kind, _ in calls]
    assert kinds.count("update") == 1 and kinds[kinds.index("update") - 1] == "predict"
    predicted = calls[kinds.index("update") - 1][1]
    expected = interpolate_pose(0.10, truth_pose(0.10), 0.15, truth_pose(0.15), 0.13)
    np.testing.assert_allclose(predicted, expected, atol=1e-9)
    np.testing.assert_allclose(predicted, truth_pose(0.13), atol=1e-4)


def test_cloud_arriving_after_newer_odometry_still_gets_its_own_pose(context):
    node = make_node(context)
    for t in np.arange(0.0, 0.41, ODOM_PERIOD):  # odometry already 0.3 s past the cloud
        deliver(node, odometry(START + t, truth_pose(t)), START + t)
    deliver(node, truth_cloud(START + 0.113), START + 0.42)
    assert node.stats["used_landmarks"] == 1 and node.stats["late_observations"] == 0
    assert node.slam.best_path()[0].tolist() == [pytest.approx(START + 0.113)]


def test_clouds_out_of_order_are_all_used(context):
    node = make_node(context)
    for t in np.arange(0.0, 1.01, ODOM_PERIOD):
        deliver(node, odometry(START + t, truth_pose(t)), START + t)
    deliver(node, truth_cloud(START + 0.92), START + 1.0)
    deliver(node, truth_cloud(START + 0.87), START + 1.0)  # older than the filter's time
    assert node.stats["used_landmarks"] == 2 and node.stats["late_observations"] == 1


def test_cloud_that_waits_too_long_uses_latest_odometry(context):
    node = make_node(context, max_observation_wait=0.5)
    for t in np.arange(0.0, 0.51, ODOM_PERIOD):
        deliver(node, odometry(START + t, truth_pose(t)), START + t)
    deliver(node, truth_cloud(START + 0.8), START + 0.55)  # odometry stops before 0.8
    assert node.stats["used_landmarks"] == 0
    deliver(node, truth_cloud(START + 1.1), START + 1.2)  # 0.65 s later: the first is stale
    assert node.stats["used_landmarks"] == 1 and node.stats["stale_observations"] == 1
    node.flush()  # end of data: the second one runs too
    assert node.stats["used_landmarks"] == 2 and node.stats["stale_observations"] == 2
    assert node.stats["dropped_stale"] == 0


def test_cloud_without_any_odometry_is_dropped_as_stale(context):
    node = make_node(context)
    deliver(node, truth_cloud(START), START)
    node.flush()
    assert node.stats["dropped_stale"] == 1 and node.stats["used_landmarks"] == 0


def test_time_going_backwards_resets_and_the_run_restarts(context):
    node = make_node(context)
    outputs = Recorder(node)
    replay(node, scripted_run(3.0))
    assert len(node.slam.best_map()) == len(LANDMARKS)
    looped = scripted_run(3.0)  # the bag loops: reset once three messages agree on it
    replay(node, looped[:2])
    assert node.stats["resets"] == 0 and node.stats["dropped_outlier_stamp"] == 2
    shown = {m.id for m in outputs.last("/fastslam/landmarks").markers
             if m.action == Marker.ADD}  # the landmarks on screen before the reset
    assert len(shown) == len(LANDMARKS)
    replay(node, looped[2:3])
    assert node.stats["time_jumps"] == 1 and node.stats["resets"] == 1
    assert node.stats["dropped_time_backwards"] == 0
    markers = outputs.last("/fastslam/landmarks").markers
    deleted = {m.id for m in markers if m.action == Marker.DELETE}
    assert deleted == shown
    replay(node, looped[3:])
    node.flush()
    assert len(node.slam.best_map()) == len(LANDMARKS)
    last_pose = outputs.last("/fastslam/pose")
    errors = pose_error(last_pose.pose.pose, ros_io.stamp_to_seconds(last_pose.header.stamp))
    assert errors[0] < POSITION_TOLERANCE and errors[1] < YAW_TOLERANCE


# --- bad input ---------------------------------------------------------------------------------

def bad_cloud(stamp: float, kind: str) -> PointCloud2:
    """A cloud with one problem; the valid points are the true ones."""
    good = sensor_points(truth_pose(stamp - START))
    if kind in ("nan", "zero_range", "beyond_range"):
        extra = {"nan": [math.nan, 1.0], "zero_range": [0.0, 0.0],
                 "beyond_range": [40.0, 0.0]}[kind]
        return cloud(stamp, np.vstack([good, extra]), np.append(LANDMARK_IDS, 99))
    msg = truth_cloud(stamp)
    if kind == "no_y":
        msg.fields = [f for f in msg.fields if f.name != "y"]
    elif kind == "bad_point_step":
        msg.point_step = 8
    elif kind == "short_data":
        msg.data = bytes(msg.data)[:-3]
    elif kind == "wrong_frame":
        msg.header.frame_id = "camera"
    elif kind == "only_nan":
        msg = cloud(stamp, [[math.nan, 0.0], [math.inf, 1.0]], [10, 11])
    return msg


def bad_odometry(stamp: float, kind: str) -> Odometry:
    msg = odometry(stamp, truth_pose(stamp - START))
    if kind == "zero_quaternion":
        msg.pose.pose.orientation.z = msg.pose.pose.orientation.w = 0.0
    elif kind == "nan_quaternion":
        msg.pose.pose.orientation.w = math.nan
    elif kind == "nan_position":
        msg.pose.pose.position.x = math.nan
    elif kind == "wrong_frame":
        msg.header.frame_id = "world"
    elif kind == "wrong_child_frame":
        msg.child_frame_id = "base_footprint"
    return msg


BAD_INPUTS = [  # (message builder, counter that must grow by 1, whether the cloud is still used)
    (lambda t: bad_cloud(t, "nan"), "dropped_nan", True),
    (lambda t: bad_cloud(t, "zero_range"), "dropped_too_close", True),
    (lambda t: bad_cloud(t, "beyond_range"), "dropped_out_of_range", True),
    (lambda t: bad_cloud(t, "no_y"), "dropped_malformed_cloud", False),
    (lambda t: bad_cloud(t, "bad_point_step"), "dropped_malformed_cloud", False),
    (lambda t: bad_cloud(t, "short_data"), "dropped_malformed_cloud", False),
    (lambda t: bad_cloud(t, "wrong_frame"), "dropped_wrong_frame", False),
    (lambda t: bad_odometry(t, "zero_quaternion"), "dropped_invalid_quaternion", False),
    (lambda t: bad_odometry(t, "nan_quaternion"), "dropped_invalid_quaternion", False),
    (lambda t: bad_odometry(t, "nan_position"), "dropped_nan", False),
    (lambda t: bad_odometry(t, "wrong_frame"), "dropped_wrong_frame", False),
    (lambda t: bad_odometry(t, "wrong_child_frame"), "dropped_wrong_frame", False),
    (lambda t: odometry(t, truth_pose(t - START)), "dropped_duplicate_stamp", False),
    (lambda t: odometry(t - 0.12, truth_pose(t - 0.12 - START)), "dropped_time_backwards", False),
    (lambda t: truth_cloud(t - 0.137), "dropped_duplicate_stamp", False),  # the last cloud's stamp
]
"""Each is built for ``t``, the stamp of the last odometry of a 1 s scripted run."""


@pytest.mark.parametrize("case", range(len(BAD_INPUTS)))
def test_bad_input_is_dropped_counted_and_the_node_keeps_working(context, case):
    build, counter, cloud_used = BAD_INPUTS[case]
    node = make_node(context, sensor_frame="laser")
    outputs = Recorder(node)
    replay(node, scripted_run(1.0))
    before = dict(node.stats)
    stamp = START + 1.0 - ODOM_PERIOD
    deliver(node, build(stamp), stamp + 0.01)
    node.flush()
    changed = {k: node.stats[k] - before[k] for k in node.stats if node.stats[k] != before[k]}
    assert changed.pop(counter) == 1
    assert changed.pop("used_landmarks", 0) == int(cloud_used)
    assert not {k for k in changed if k.startswith("dropped_")}, changed
    replay(node, scripted_run(1.0, begin=1.0))
    node.flush()
    assert node.stats["used_landmarks"] > before["used_landmarks"] + 3
    last_pose = outputs.last("/fastslam/pose")
    errors = pose_error(last_pose.pose.pose, ros_io.stamp_to_seconds(last_pose.header.stamp))
    assert errors[0] < POSITION_TOLERANCE and errors[1] < YAW_TOLERANCE


def test_cloud_whose_points_are_all_invalid_is_not_used(context):
    node = make_node(context)
    replay(node, scripted_run(1.0))
    used, existence = node.stats["used_landmarks"], node.slam.best_map().existence.copy()
    deliver(node, bad_cloud(START + 0.98, "only_nan"), START + 1.0)
    node.flush()
    assert node.stats["dropped_nan"] == 2 and node.stats["used_landmarks"] == used
    np.testing.assert_array_equal(node.slam.best_map().existence, existence)


def test_empty_cloud_is_used_and_lowers_existence(context):
    node = make_node(context)
    replay(node, scripted_run(1.0))
    existence = node.slam.best_map().existence.copy()
    before = dict(node.stats)
    deliver(node, cloud(START + 0.98, np.zeros((0, 2))), START + 1.0)
    node.flush()
    assert node.stats["used_landmarks"] == before["used_landmarks"] + 1
    assert node.stats["observations_used"] == before["observations_used"]
    assert np.all(node.slam.best_map().existence < existence)


def test_known_association_drops_points_without_id(context):
    node = make_node(context, association="known")
    replay(node, scripted_run(1.0))
    used = node.stats["observations_used"]
    points = sensor_points(truth_pose(0.98))
    ids = LANDMARK_IDS.copy()
    ids[[2, 5]] = -1
    deliver(node, cloud(START + 0.98, points, ids), START + 1.0)
    deliver(node, cloud(START + 0.99, points), START + 1.0)  # no id field at all: all missing
    node.flush()
    assert node.stats["dropped_missing_id"] == 2 + len(LANDMARKS)
    assert node.stats["observations_used"] == used + len(LANDMARKS) - 2
    assert node.stats["associations_checked"] == 0  # ids are the association, not a check


def test_exception_inside_a_callback_is_counted_not_raised(context):
    node = make_node(context)
    node.on_odometry(None)
    node.on_landmarks(object())
    assert node.stats["dropped_internal_error"] == 2
    replay(node, scripted_run(0.5))
    assert node.stats["used_landmarks"] == 2


# --- parameters --------------------------------------------------------------------------------

@pytest.mark.parametrize("name, value", [
    ("num_particles", 0), ("sigma_range", -0.1), ("sigma_range", 1), ("algorithm", "fastslam3"),
    ("association", "nearest"), ("resampling", "best"), ("new_landmark_gate", 1.0),
    ("resample_threshold", 0.0), ("cell_size", 1e-300), ("num_particle", 50),
    ("pose_estimate", "median"), ("max_observation_wait", -1.0), ("map_frame", ""),
])
def test_bad_parameter_stops_the_start_naming_it(context, name, value):
    with pytest.raises(ParameterError, match=f"'{name}'"):
        make_node(context, **{name: value})


def test_a_rule_between_two_parameters_names_both(context):
    with pytest.raises(ParameterError, match="'min_range', 'max_range'"):
        make_node(context, min_range=40.0, max_range=30.0)


def test_unknown_name_in_a_parameter_file_stops_the_start(tmp_path):
    path = tmp_path / "typo.yaml"
    path.write_text("/**:\n  ros__parameters:\n    sigma_rang: 0.2\n    num_particles: 5\n")
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID, args=["--ros-args", "--params-file", str(path)])
    try:
        with pytest.raises(ParameterError, match="unknown parameter 'sigma_rang'"):
            FastSLAMNode(context=ctx)
    finally:
        rclpy.shutdown(context=ctx)


def test_a_failed_start_leaves_no_node_behind(context):
    with pytest.raises(ParameterError) as failure:
        make_node(context, num_particles=0)
    probe = Node("probe", context=context)
    try:
        # The half-built node is still alive (its frame is in the traceback), so only an
        # explicit destroy, not the garbage collector, can have removed it from the graph.
        assert any(isinstance(entry.frame.f_locals.get("self"), FastSLAMNode)
                   for entry in failure.traceback)
        assert "fastslam" not in probe.get_node_names()
        assert "probe" in probe.get_node_names()
    finally:
        probe.destroy_node()


def test_runtime_parameter_changes(context):
    node = make_node(context)
    result = node.set_parameters([Parameter("num_particles", value=10)])[0]
    assert not result.successful and "restart" in result.reason
    assert node.get_parameter("num_particles").value == 40
    assert not node.set_parameters([Parameter("pose_estimate", value="median")])[0].successful
    assert node.set_parameters([Parameter("markers_rate", value=0.0),
                                Parameter("pose_estimate", value="mean")])[0].successful
    assert node.settings["pose_estimate"] == "mean"
    outputs = Recorder(node)
    replay(node, scripted_run(2.0))
    assert outputs.count("/fastslam/landmarks") == 0  # rate 0: never
    assert outputs.count("/fastslam/pose") == node.stats["used_landmarks"] > 0


def test_every_parameter_is_declared_with_a_description(context):
    node = make_node(context)
    specs = {**CORE_PARAMETERS, **NODE_PARAMETERS}
    for descriptor in node.describe_parameters(list(specs)):
        default, spec = specs[descriptor.name]
        assert descriptor.description.startswith(spec.description), descriptor.name
        # Every string parameter with choices names them; every number carries its range.
        if spec.choices is not None:
            assert f"One of: {' | '.join(spec.choices)}." in descriptor.description
        elif isinstance(default, int) and not isinstance(default, bool):
            ranges = descriptor.integer_range or descriptor.floating_point_range
            assert (ranges[0].from_value, ranges[0].to_value) == (spec.low, spec.high)
    assert {"algorithm", "association", "best_particle", "pose_estimate"} <= {
        name for name, (_, spec) in specs.items() if spec.choices}
    number = node.describe_parameters(["num_particles", "resample_threshold"])
    assert number[0].integer_range[0].from_value == 1
    assert number[1].floating_point_range[0].to_value == 1.0


def test_yaml_file_lists_every_parameter_and_loads_in_a_namespace(tmp_path):
    yaml = pytest.importorskip("yaml")
    text = (REPO / "config" / "fastslam.yaml").read_text()
    (key, content), = yaml.safe_load(text).items()
    assert list(content["ros__parameters"]) == [*CORE_PARAMETERS, *NODE_PARAMETERS]
    changed = tmp_path / "changed.yaml"
    changed.write_text(text.replace("num_particles: 100\n", "num_particles: 7\n"))
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID, args=["--ros-args", "--params-file", str(changed)])
    try:
        node = FastSLAMNode(context=ctx, namespace="robot1")
        assert node.config.num_particles == 7  # the file's key matches the namespaced node
        for name, value in content["ros__parameters"].items():
            if name != "num_particles":
                assert node.get_parameter(name).value == pytest.approx(value), name
        node.destroy_node()
    finally:
        rclpy.shutdown(context=ctx)


def test_a_shipped_file_applies_to_a_namespaced_node():
    yaml = pytest.importorskip("yaml")
    path = REPO / "config" / "mrclam.yaml"
    (key, content), = yaml.safe_load(path.read_text()).items()
    assert key == "/**"
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID, args=["--ros-args", "--params-file", str(path)])
    try:
        node = FastSLAMNode(context=ctx, namespace="robot1")
        for name, value in content["ros__parameters"].items():
            assert node.get_parameter(name).value == pytest.approx(value), name
        assert node.config.association == "monte_carlo"
        node.destroy_node()
    finally:
        rclpy.shutdown(context=ctx)


@pytest.mark.parametrize("arguments, named, status", [
    (["-p", "sigma_bearing:=-1.0"], "sigma_bearing", 1),
    (["-p", "num_particle:=50"], "num_particle", 1),
    (["-p", 'use_sim_time:="true"'], "use_sim_time", 1),
    (["-p", "sigma_range:=1"], "write 1.0", 1),
    (["--params-file", "/nonexistent/params.yaml"], "/nonexistent/params.yaml", 2),
])
def test_main_exits_non_zero_with_one_line_naming_the_parameter(arguments, named, status):
    result = subprocess.run(
        [sys.executable, "-m", "fastslam_ros.node", "--ros-args", *arguments],
        capture_output=True, text=True, timeout=60,
        env={**os.environ, "ROS_DOMAIN_ID": str(DOMAIN_ID)})
    assert result.returncode == status
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and named in lines[0], result.stderr


# --- over DDS ----------------------------------------------------------------------------------

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def spin_until(executor: SingleThreadedExecutor, done, what: str) -> None:
    """Spin until ``done()``; fail (no wait on timing otherwise) after SPIN_LIMIT s."""
    deadline = time.monotonic() + SPIN_LIMIT
    while not done():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        executor.spin_once(timeout_sec=0.05)


def test_dds_run_reliable_inputs_late_map_subscriber_save_and_reset(context, tmp_path):
    yaml = pytest.importorskip("yaml")
    node = make_node(context, live=True, use_sim_time=False,
                     save_map_file=str(tmp_path / "map.yaml"))
    driver = Node("driver", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    executor.add_node(driver)
    try:
        # Reliable writers, as `ros2 bag play` uses by default: the best-effort readers connect.
        odom_pub = driver.create_publisher(Odometry, "/odom", RELIABLE)
        cloud_pub = driver.create_publisher(PointCloud2, "/landmarks", RELIABLE)
        poses: list[PoseWithCovarianceStamped] = []
        driver.create_subscription(PoseWithCovarianceStamped, "/fastslam/pose", poses.append, 100)
        spin_until(executor, lambda: odom_pub.get_subscription_count() and
                   cloud_pub.get_subscription_count(), "input connections")

        events = scripted_run(2.0)
        for event in events:
            is_odometry = isinstance(event.msg, Odometry)
            counter = "received_odom" if is_odometry else "received_landmarks"
            expected = node.stats[counter] + 1
            (odom_pub if is_odometry else cloud_pub).publish(event.msg)
            spin_until(executor, lambda: node.stats[counter] == expected, counter)
        clouds = sum(isinstance(e.msg, PointCloud2) for e in events)
        spin_until(executor, lambda: len(poses) == clouds, "every pose")
        assert node.stats["used_landmarks"] == clouds
        errors = pose_error(poses[-1].pose.pose, ros_io.stamp_to_seconds(poses[-1].header.stamp))
        assert errors[0] < POSITION_TOLERANCE and errors[1] < YAW_TOLERANCE
        node.flush()

        maps: list[MarkerArray] = []  # subscribes after the map was published
        driver.create_subscription(MarkerArray, "/fastslam/landmarks", maps.append, LATCHED)
        spin_until(executor, lambda: maps, "the latched map")
        assert ellipse_count(maps[-1]) == len(LANDMARKS)
        assert sorted(int(m.text) for m in maps[-1].markers
                      if m.type == Marker.TEXT_VIEW_FACING) == LANDMARK_IDS.tolist()

        def call(service: str) -> Trigger.Response:
            client = driver.create_client(Trigger, service)
            spin_until(executor, client.service_is_ready, service)
            future = client.call_async(Trigger.Request())
            spin_until(executor, future.done, f"{service} response")
            return future.result()

        saved = call("/fastslam/save_map")
        assert saved.success, saved.message
        assert "refined by least squares" in saved.message
        rows = yaml.safe_load((tmp_path / "map.yaml").read_text())["landmarks"]
        assert sorted(row["id"] for row in rows) == LANDMARK_IDS.tolist()
        assert all(0.0 < row["cov_xx"] < 0.1 and 0.5 < row["existence"] <= 1.0 for row in rows)

        reset = call("/fastslam/reset")
        assert reset.success and node.stats["resets"] == 1
        assert len(node.slam.best_map()) == 0
        spin_until(executor, lambda: len(maps) >= 2, "the map after reset")
        assert ellipse_count(maps[-1]) == 0
        assert sum(m.action == Marker.DELETE for m in maps[-1].markers) == 2 * len(LANDMARKS)
    finally:
        executor.shutdown()
        driver.destroy_node()


def test_output_types_and_topics_over_dds(context):
    node = make_node(context, use_sim_time=False)
    names = {name: types for name, types in node.get_publisher_names_and_types_by_node(
        "fastslam", "/")}
    assert names["/fastslam/pose"] == ["geometry_msgs/msg/PoseWithCovarianceStamped"]
    assert names["/fastslam/path"] == ["nav_msgs/msg/Path"]
    assert names["/fastslam/landmarks"] == ["visualization_msgs/msg/MarkerArray"]
    assert names["/fastslam/map_cloud"] == ["sensor_msgs/msg/PointCloud2"]
    assert names["/fastslam/particles"] == ["geometry_msgs/msg/PoseArray"]
    assert names["/fastslam/map_to_odom"] == ["geometry_msgs/msg/TransformStamped"]
    assert names["/diagnostics"] == ["diagnostic_msgs/msg/DiagnosticArray"]
    subscriptions = dict(node.get_subscriber_names_and_types_by_node("fastslam", "/"))
    assert subscriptions["/odom"] == ["nav_msgs/msg/Odometry"]
    assert subscriptions["/landmarks"] == ["sensor_msgs/msg/PointCloud2"]
    services = dict(node.get_service_names_and_types_by_node("fastslam", "/"))
    assert services["/fastslam/reset"] == services["/fastslam/save_map"] == ["std_srvs/srv/Trigger"]
    for topic in ("/fastslam/landmarks", "/fastslam/map_cloud"):
        qos = node.get_publishers_info_by_topic(topic)[0].qos_profile
        assert qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
        assert qos.reliability == ReliabilityPolicy.RELIABLE


def test_a_max_range_far_beyond_what_the_sensor_sees_is_reported_once(context):
    """The scripted landmarks are at most ~8 m away: max_range 30 m would let negative evidence
    remove landmarks the sensor cannot see; the node says so once and /diagnostics stays WARN."""
    node = make_node(context, max_range=30.0)
    outputs = Recorder(node)
    replay(node, scripted_run(16.0))
    node.flush()
    assert node.stats["observations_used"] >= 500
    status = outputs.last("/diagnostics").status[0]
    assert "sensor reach" in status.message and "max_range is 30 m" in status.message

    fitting = make_node(context, max_range=9.0)
    fitting_outputs = Recorder(fitting)
    replay(fitting, scripted_run(16.0))
    fitting.flush()
    assert fitting.stats["dropped_out_of_range"] == 0
    assert "sensor reach" not in fitting_outputs.last("/diagnostics").status[0].message
