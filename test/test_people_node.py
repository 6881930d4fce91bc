# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""PeopleTrackerNode with real rclpy, driven through its callbacks on a simulated clock (as a
bag replay does), and the people_io conversions it relies on."""
from __future__ import annotations

import math

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.context import Context
from rclpy.parameter import Parameter
from rclpy.time import Time
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Header

from fastslam_ros import people_io, ros_io
from fastslam_ros.node import ParameterError
from fastslam_ros.people_node import PeopleTrackerNode
from fastslam_ros.tools.bags.in_process import in_process
from fastslam_ros.tools.bags.bag_schema import cloud_to_arrays
from fastslam_ros.tools.simulation.people_sim import cast_scan
from test_people_core import ANGLES, room

BASE = {"scan_frame": "laser", "seed": 1, "num_particles": 20, "people_particles": 20,
        "max_people": 4,
        "global_particles": 500, "use_sim_time": True}
POSE = np.array([2.0, 5.0, 0.0])
PERSON = np.array([6.0, 5.5])


def make_node(context, **params) -> PeopleTrackerNode:
    overrides = [Parameter(k, value=v) for k, v in {**BASE, **params}.items()]
    node = in_process(PeopleTrackerNode)(context=context, parameter_overrides=overrides,
                                         enable_rosout=False)
    return node


def header(stamp: float, frame: str) -> Header:
    return Header(stamp=ros_io.seconds_to_stamp(stamp), frame_id=frame)


def map_message(grid) -> OccupancyGrid:
    msg = OccupancyGrid(header=header(0.0, "map"))
    msg.info.resolution = grid.resolution
    msg.info.height, msg.info.width = grid.shape
    msg.info.origin.orientation.w = 1.0
    msg.data = np.where(grid.occupied, 100, 0).astype(np.int8).ravel().tolist()
    return msg


def scan_message(stamp: float, ranges: np.ndarray) -> LaserScan:
    return LaserScan(header=header(stamp, "laser"), angle_min=float(ANGLES[0]),
                     angle_max=float(ANGLES[-1]), angle_increment=float(ANGLES[1] - ANGLES[0]),
                     range_min=0.05, range_max=12.0, ranges=ranges.astype(np.float32).tolist())


def odometry_message(stamp: float, pose) -> Odometry:
    msg = Odometry(header=header(stamp, "odom"), child_frame_id="base_link")
    msg.pose.pose = ros_io.pose_msg(pose)
    return msg


def initial_pose_message(pose) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped(header=header(0.0, "map"))
    msg.pose.pose = ros_io.pose_msg(pose)
    covariance = np.zeros(36)
    covariance[0] = covariance[7] = 1e-4
    covariance[35] = 1e-4
    msg.pose.covariance = covariance.tolist()
    return msg


def drive(node: PeopleTrackerNode, grid, steps: int, start: float = 0.0, people=(PERSON,)):
    """A robot standing at POSE (odometry at the origin) seeing ``people``: 10 Hz scans."""
    clock = node.get_clock()
    for k in range(steps):
        stamp = start + 0.1 * k
        clock.set_ros_time_override(Time(nanoseconds=int(stamp * 1e9)))
        node.on_odometry(odometry_message(stamp, (0.0, 0.0, 0.0)))
        node.on_odometry(odometry_message(stamp + 0.05, (0.0, 0.0, 0.0)))
        ranges = cast_scan(grid, POSE, ANGLES, np.asarray(people).reshape(-1, 2), 12.0)
        node.on_scan(scan_message(stamp + 0.02, ranges))


def test_node_tracks_a_person_and_counts_bad_input(context):
    grid = room()
    node = make_node(context)
    outputs = []
    node.output_listeners.append(lambda topic, msg: outputs.append((topic, msg)))
    try:
        node.on_map(map_message(grid))
        node.on_initial_pose(initial_pose_message(POSE))
        drive(node, grid, 10)
        # bad input: each is dropped and counted, none stops the tracker
        bad_scan = scan_message(5.0, np.ones(10))
        bad_scan.angle_increment = 0.0
        node.on_scan(bad_scan)
        node.on_map(OccupancyGrid(header=header(0.0, "map")))          # 0 x 0 cells
        odometry = odometry_message(5.0, (0.0, 0.0, 0.0))
        odometry.pose.pose.orientation.w = 0.0
        node.on_odometry(odometry)
        wrong_frame = scan_message(0.57, np.full(360, np.inf))
        wrong_frame.header.frame_id = "camera"
        node.on_scan(wrong_frame)
        drive(node, grid, 10, start=1.0)
        node.flush()
        stats = node.stats
        assert stats["dropped_malformed_scan"] == 1
        assert stats["dropped_malformed_map"] == 1
        assert stats["dropped_invalid_quaternion"] == 1
        assert stats["dropped_wrong_frame"] == 1
        assert stats["used_scan"] == 20
        clouds = [msg for topic, msg in outputs if topic.endswith("/people")]
        assert len(clouds) == 20
        fields = cloud_to_arrays(clouds[-1])
        assert set(fields) >= {"x", "y", "z", "id", "cov_xx", "cov_xy", "cov_yy", "existence"}
        assert len(fields["x"]) == 1
        assert math.hypot(fields["x"][0] - PERSON[0], fields["y"][0] - PERSON[1]) < 0.2
        poses = [msg for topic, msg in outputs if topic.endswith("/pose")]
        position = poses[-1].pose.pose.position
        assert math.hypot(position.x - POSE[0], position.y - POSE[1]) < 0.1
        transforms = [msg for topic, msg in outputs if topic.endswith("/map_to_odom")]
        assert transforms[-1].transform.translation.x == pytest.approx(POSE[0], abs=0.1)
        assert any(topic == "/diagnostics" for topic, _ in outputs)
    finally:
        node.destroy_node()


def test_scans_before_the_map_are_dropped_and_counted(context):
    grid = room()
    node = make_node(context)
    try:
        drive(node, grid, 3)
        node.flush()
        assert node.stats["dropped_no_map"] == 3
        node.on_map(map_message(grid))
        assert node.tracker.globally_localizing
    finally:
        node.destroy_node()


@pytest.mark.parametrize("name, value, words", [
    ("people_particles", 0, "people_particles"),
    ("pose_estimate", "median", "pose_estimate"),
    ("person_motion", "kalman", "person_motion"),
    ("no_such_parameter", 1.0, "no_such_parameter"),
    ("map_file", "/nonexistent/map.yaml", "map_file"),
])
def test_bad_parameters_fail_at_start_naming_the_parameter(context, name, value, words):
    with pytest.raises(ParameterError, match=words):
        make_node(context, **{name: value})


def test_nav2_map_file_reads_like_the_grid(tmp_path):
    from PIL import Image
    grid = room([(6.0, 6.2, 2.0, 5.0)])
    pixels = np.where(grid.occupied, 0, 254).astype(np.uint8)[::-1]   # image row 0 on top
    Image.fromarray(pixels).save(tmp_path / "room.pgm")
    (tmp_path / "room.yaml").write_text(
        "image: room.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.25\n")
    loaded = people_io.load_map_file(tmp_path / "room.yaml", grid.max_distance)
    np.testing.assert_array_equal(loaded.occupied, grid.occupied)
    np.testing.assert_array_equal(loaded.free, grid.free)


def test_read_scan_keeps_inf_as_no_return_and_invalid_ranges_as_no_evidence():
    ranges = np.array([1.0, np.nan, -np.inf, 0.01, 13.0, 2.0, np.inf, -1.0])
    msg = LaserScan(angle_min=-0.1, angle_max=-0.1 + 7 * 0.04, angle_increment=0.04,
                    range_min=0.05, range_max=12.0, ranges=ranges.astype(np.float32).tolist())
    scan = people_io.read_scan(msg)
    assert np.isnan(scan.ranges[[1, 2, 3, 4, 7]]).all()   # REP 117: no evidence
    assert scan.ranges[6] == np.inf                       # nothing within range_max
    returns = scan.returns(0.1, 12.0)
    np.testing.assert_array_equal(returns, [True, False, False, False, False, True, False,
                                            False])
    with pytest.raises(ros_io.MalformedScanError):
        people_io.read_scan(LaserScan(angle_increment=0.0, ranges=[1.0]))


def test_yaml_and_docs_follow_the_parameter_specs():
    """config/people_tracker.yaml and docs/people.md list every parameter at its default."""
    from pathlib import Path

    import yaml

    from fastslam_ros.people_node import parameter_specs
    repo = Path(__file__).resolve().parents[1]
    values = yaml.safe_load((repo / "config" / "people_tracker.yaml").read_text())
    values = values["/**"]["ros__parameters"]
    docs = (repo / "docs" / "people.md").read_text()
    specs = parameter_specs()
    assert set(values) == set(specs)
    for name, (default, _) in specs.items():
        assert values[name] == default, name
        assert f"| `{name}` | {default!r} |" in docs, name



def test_node_publishes_only_people_within_publish_spread(context):
    """~/people and /diagnostics hold the tracker's published people: with publish_spread
    below a tracked person's spread, the person is tracked but not on ~/people."""
    grid = room()
    node = make_node(context, publish_spread=0.01)
    outputs = []
    node.output_listeners.append(lambda topic, msg: outputs.append((topic, msg)))
    try:
        node.on_map(map_message(grid))
        node.on_initial_pose(initial_pose_message(POSE))
        drive(node, grid, 10)
        node.flush()
        assert len(node.tracker.people_of().keys) == 1
        clouds = [msg for topic, msg in outputs if topic.endswith("/people")]
        assert len(clouds) == 10
        assert all(len(cloud_to_arrays(cloud)["x"]) == 0 for cloud in clouds)
    finally:
        node.destroy_node()

# --- bad-input gates (the SLAM node's, test_faults.py): dropped, counted, estimate unchanged ----

INJECT_AT = 10
"""Step of the stream after which the bad message arrives (1 s into the run)."""
START = 100.0
"""Stamp (s) of the stream's first message."""


def stream(grid, steps: int = 20, start: float = START) -> list[tuple[float, str, object]]:
    """``drive``'s messages as (arrival, callback, message), with the map and initial pose."""
    events = [(start, "on_map", map_message(grid)), (start, "on_initial_pose",
                                                     initial_pose_message(POSE))]
    for k in range(steps):
        stamp = start + 0.1 * k
        ranges = cast_scan(grid, POSE, ANGLES, PERSON.reshape(1, 2), 12.0)
        events += [(stamp, "on_odometry", odometry_message(stamp, (0.0, 0.0, 0.0))),
                   (stamp, "on_odometry", odometry_message(stamp + 0.05, (0.0, 0.0, 0.0))),
                   (stamp, "on_scan", scan_message(stamp + 0.02, ranges))]
    return events


def feed(context, events) -> tuple[dict, dict]:
    """Run the events through a fresh node; its counters and its estimate."""
    node = make_node(context)
    try:
        clock = node.get_clock()
        for arrival, callback, msg in events:
            clock.set_ros_time_override(Time(nanoseconds=round(arrival * 1e9)))
            getattr(node, callback)(msg)
        node.flush()
        people = node.tracker.people_of()
        estimate = {"poses": node.tracker.poses.copy(),
                    "log_weights": node.tracker.log_weights.copy(),
                    "people": people.means.copy(), "keys": people.keys.copy()}
        return dict(node.stats), estimate
    finally:
        node.destroy_node()


def inserted(grid, msg, callback: str) -> list:
    events = stream(grid)
    at = 2 + 3 * INJECT_AT
    return events[:at] + [(events[at - 1][0], callback, msg)] + events[at:]


def shifted_odometry(offset=(0.0, 0.0, 0.0), seconds: float = 0.0) -> Odometry:
    """An odometry message between two of the stream's, moved by ``offset`` and ``seconds``."""
    stamp = START + 0.1 * (INJECT_AT - 1) + 0.075 + seconds
    return odometry_message(stamp, np.asarray(offset, float))


def scan_at(seconds: float) -> LaserScan:
    return scan_message(START + 0.1 * (INJECT_AT - 1) + 0.03 + seconds,
                        cast_scan(room(), POSE, ANGLES, PERSON.reshape(1, 2), 12.0))


def with_stamp(msg, sec: int, nanosec: int):
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    return msg


PEOPLE_FAULTS = {  # name -> (message builder, callback, counter)
    "odometry +100 m": (lambda: shifted_odometry((100.0, 0.0, 0.0)), "on_odometry",
                        "dropped_implausible_odometry"),
    "odometry half turn": (lambda: shifted_odometry((0.0, 0.0, 3.0)), "on_odometry",
                           "dropped_implausible_odometry"),
    "odometry x = 1e308": (lambda: shifted_odometry((1e308, 0.0, 0.0)), "on_odometry",
                           "dropped_implausible_odometry"),
    "odometry 1 h ahead": (lambda: shifted_odometry(seconds=3600.0), "on_odometry",
                           "dropped_outlier_stamp"),
    "odometry 1 min behind": (lambda: shifted_odometry(seconds=-60.0), "on_odometry",
                            "dropped_outlier_stamp"),
    "odometry older": (lambda: shifted_odometry(seconds=-0.06), "on_odometry",
                       "dropped_time_backwards"),
    "odometry nanosec 2^32-1": (lambda: with_stamp(shifted_odometry(), 0, 2**32 - 1),
                                "on_odometry", "dropped_invalid_stamp"),
    "scan 1 h ahead": (lambda: scan_at(3600.0), "on_scan", "dropped_outlier_stamp"),
    "scan nanosec 1e9": (lambda: with_stamp(scan_at(0.0), 1, 1_000_000_000), "on_scan",
                         "dropped_invalid_stamp"),
}
RECEIVED = {"on_odometry": "received_odom", "on_scan": "received_scan"}


@pytest.fixture(scope="module")
def module_context():
    ctx = Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.shutdown(context=ctx)


@pytest.fixture(scope="module")
def clean_run(module_context):
    stats, estimate = feed(module_context, stream(room()))
    assert not any(v for k, v in stats.items() if k.startswith("dropped_"))
    assert stats["used_scan"] == 20 and stats["used_odom"] == 40
    return stats, estimate


@pytest.mark.parametrize("name", PEOPLE_FAULTS)
def test_people_node_gates_drop_count_and_change_nothing(module_context, clean_run, name):
    build, callback, counter = PEOPLE_FAULTS[name]
    stats, estimate = feed(module_context, inserted(room(), build(), callback))
    changed = {k: stats[k] - clean_run[0][k] for k in stats if stats[k] != clean_run[0][k]}
    assert changed == {counter: 1, RECEIVED[callback]: 1}
    for key, value in clean_run[1].items():
        np.testing.assert_array_equal(estimate[key], value, err_msg=key)


def test_people_node_resets_once_on_a_confirmed_loop_only(module_context, clean_run):
    """The stream played twice (a looped bag): one reset, after three messages agree on the
    earlier time; the two outliers before that are dropped."""
    grid = room()
    second = [(arrival + 2.5, callback, msg) for arrival, callback, msg in stream(grid)[2:]]
    stats, estimate = feed(module_context, stream(grid) + second)
    assert stats["time_jumps"] == stats["resets"] == 1
    assert stats["dropped_outlier_stamp"] == 2
    assert np.isfinite(estimate["poses"]).all()


def test_people_node_bridges_a_confirmed_odometry_restart(module_context, clean_run):
    """From INJECT_AT on the odometry reads 100 m further east: four messages are dropped, the
    fifth confirms the restart, which is bridged with no motion."""
    events = []
    for arrival, callback, msg in stream(room()):
        if callback == "on_odometry" and arrival >= START + 0.1 * INJECT_AT:
            msg = odometry_message(ros_io.stamp_to_seconds(msg.header.stamp), (100.0, 0.0, 0.0))
        events.append((arrival, callback, msg))
    stats, estimate = feed(module_context, events)
    assert stats["odometry_jumps"] == 1
    assert stats["dropped_implausible_odometry"] == 4
    assert stats["used_scan"] == 20
    mean = np.average(estimate["poses"][:, :2], axis=0, weights=np.exp(estimate["log_weights"]))
    assert np.linalg.norm(mean - POSE[:2]) < 0.2  # where the robot stands, not 100 m off


def test_people_node_parameters_change_at_runtime_as_the_slam_nodes(context):
    """ROS-side parameters change at runtime (validated); the tracker's are fixed at start."""
    node = make_node(context)
    try:
        assert node.set_parameters([Parameter("markers_rate", value=0.5)])[0].successful
        assert node.settings["markers_rate"] == 0.5 and node._throttles["markers_rate"].rate == 0.5
        refused = node.set_parameters([Parameter("max_speed", value=-1.0)])[0]
        assert not refused.successful and node.settings["max_speed"] == 20.0
        # In the descriptor's range but refused by the node's own validation.
        refused = node.set_parameters([Parameter("map_frame", value="")])[0]
        assert not refused.successful and "map_frame" in refused.reason
        assert node.settings["map_frame"] == "map"
        fixed = node.set_parameters([Parameter("num_particles", value=50)])[0]
        assert not fixed.successful and "restart" in fixed.reason
        assert node.tracker_settings.num_particles == 20
        # Read once at start (file or subscription): refused, not accepted and ignored.
        fixed = node.set_parameters([Parameter("map_file", value="/tmp/other_map.yaml")])[0]
        assert not fixed.successful and "map_file" in fixed.reason and "start" in fixed.reason
        assert node.get_parameter("map_file").value == ""
    finally:
        node.destroy_node()


@pytest.mark.parametrize("deskew, sweep, corrected", [(True, 0.1, True), (False, 0.1, False),
                                                      (True, 100.0, False)])
def test_node_deskews_a_swept_scan_by_the_odometrys_turn(context, deskew, sweep, corrected):
    """Odometry turning at 0.5 rad/s and scans 0.1 s apart whose beams sweep ``sweep`` s: the
    tracker gets each scan with its bearings 0.5 x time_increment rad further apart
    (``deskew_scans``; the odometry over the sweep, the last scan's since the previous scan),
    or as sent; a sweep of 100 s (a time_increment in milliseconds) cannot fit 0.1 s and is
    taken as sent, counted."""
    grid = room()
    node = make_node(context, deskew_scans=deskew)
    time_increment = sweep / len(ANGLES)
    seen = []
    update = node.tracker.update

    def spy(stamp, scan):
        seen.append(scan)
        return update(stamp, scan)
    node.tracker.update = spy
    try:
        node.on_map(map_message(grid))
        node.on_initial_pose(initial_pose_message(POSE))
        clock = node.get_clock()
        for k in range(6):
            stamp = 0.1 * k
            clock.set_ros_time_override(Time(nanoseconds=int(stamp * 1e9)))
            for t in (stamp, stamp + 0.05):
                node.on_odometry(odometry_message(t, (0.0, 0.0, 0.5 * t)))
            scan = scan_message(stamp + 0.02, cast_scan(grid, POSE, ANGLES, np.zeros((0, 2)),
                                                        12.0))
            scan.time_increment = time_increment
            node.on_scan(scan)
        node.flush()
    finally:
        node.destroy_node()
    increment = float(ANGLES[1] - ANGLES[0])
    assert len(seen) >= 4
    np.testing.assert_allclose([s.angle_increment for s in seen],
                               increment + (0.5 * time_increment if corrected else 0.0),
                               rtol=1e-6)
    assert node.stats["scans_not_deskewed"] == (0 if corrected or not deskew else len(seen) - 1)
