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
from fastslam_ros.tools.bag_schema import cloud_to_arrays
from fastslam_ros.tools.people_sim import cast_scan
from test_people_core import ANGLES, room

BASE = {"scan_frame": "laser", "seed": 1, "num_particles": 20, "people_particles": 20,
        "max_people": 4,
        "global_particles": 500, "use_sim_time": True}
POSE = np.array([2.0, 5.0, 0.0])
PERSON = np.array([6.0, 5.5])


@pytest.fixture
def context():
    ctx = Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.shutdown(context=ctx)


def make_node(context, **params) -> PeopleTrackerNode:
    overrides = [Parameter(k, value=v) for k, v in {**BASE, **params}.items()]
    node = PeopleTrackerNode(context=context, parameter_overrides=overrides, enable_rosout=False)
    node.publish_to_dds = False
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


def test_read_scan_maps_invalid_ranges_to_no_return():
    ranges = np.array([1.0, np.nan, -np.inf, 0.01, 13.0, 2.0])
    msg = LaserScan(angle_min=-0.1, angle_increment=0.04, range_min=0.05, range_max=12.0,
                    ranges=ranges.astype(np.float32).tolist())
    scan = people_io.read_scan(msg)
    assert np.isinf(scan.ranges[[1, 2, 3]]).all()
    returns = scan.returns(0.1, 12.0)
    np.testing.assert_array_equal(returns, [True, False, False, False, False, True])
    with pytest.raises(people_io.MalformedScanError):
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
