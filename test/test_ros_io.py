# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Message <-> numpy conversions of fastslam_ros.ros_io (no ROS graph needed)."""
from __future__ import annotations

import csv
import math
from types import SimpleNamespace

import numpy as np
import pytest
from geometry_msgs.msg import Quaternion
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header
from visualization_msgs.msg import Marker

from fastslam_ros import map_files, ros_io, ros_markers
from fastslam_ros.core import geometry

HEADER = Header(frame_id="map", stamp=ros_io.seconds_to_stamp(12.5))


def example_map() -> SimpleNamespace:
    """Three landmarks; the second has an unknown id and a tilted covariance."""
    rotation = np.array([[math.cos(0.5), -math.sin(0.5)], [math.sin(0.5), math.cos(0.5)]])
    return SimpleNamespace(
        means=np.array([[1.0, 2.0], [-3.0, 0.5], [4.0, -4.0]]),
        covariances=np.array([np.diag([4.0, 1.0]), rotation @ np.diag([0.09, 0.01]) @ rotation.T,
                              np.diag([0.01, 0.01])]),
        existence=np.array([0.9, 0.6, 0.99]),
        ids=np.array([7, -1, 3], np.int64),
        keys=np.array([0, 4, 9], np.int64))


def field(name: str, offset: int, datatype: int) -> PointField:
    return PointField(name=name, offset=offset, datatype=datatype, count=1)


@pytest.mark.parametrize("yaw", [0.0, 0.3, -2.0, math.pi - 1e-9, -math.pi + 1e-9, 3.0])
def test_yaw_quaternion_round_trip(yaw):
    assert ros_io.quaternion_to_yaw(ros_io.yaw_to_quaternion(yaw)) == pytest.approx(yaw, abs=1e-9)


def test_quaternion_to_yaw_normalises_and_keeps_pi_positive():
    q = ros_io.yaw_to_quaternion(1.2)
    scaled = Quaternion(x=q.x * 3, y=q.y * 3, z=q.z * 3, w=q.w * 3)
    assert ros_io.quaternion_to_yaw(scaled) == pytest.approx(1.2)
    assert ros_io.quaternion_to_yaw(Quaternion(z=1.0, w=0.0)) == pytest.approx(math.pi)


@pytest.mark.parametrize("quaternion", [Quaternion(w=0.0), Quaternion(x=math.nan, w=1.0),
                                        Quaternion(z=math.inf, w=1.0)])
def test_invalid_quaternion_raises(quaternion):
    with pytest.raises(ros_io.InvalidQuaternionError):
        ros_io.quaternion_to_yaw(quaternion)


def test_stamp_round_trip_and_nanosecond_split():
    stamp = ros_io.seconds_to_stamp(1234.000000007)
    assert (stamp.sec, stamp.nanosec) == (1234, 7)
    assert ros_io.stamp_to_seconds(stamp) == pytest.approx(1234.000000007, abs=1e-12)


def test_odometry_pose_reads_position_and_yaw():
    msg = SimpleNamespace(pose=SimpleNamespace(pose=ros_io.pose_msg((1.5, -2.0, 0.7))))
    np.testing.assert_allclose(ros_io.odometry_pose(msg), [1.5, -2.0, 0.7])
    msg.pose.pose.position.y = math.nan
    with pytest.raises(ros_io.NonFiniteError):
        ros_io.odometry_pose(msg)


def test_landmark_cloud_round_trip_with_ids():
    points = np.array([[1.0, 2.0], [-0.5, 3.25], [10.0, -4.0]])
    msg = ros_io.landmark_cloud(HEADER, points, np.array([4, -1, 12]))
    assert [f.name for f in msg.fields] == ["x", "y", "z", "id"]
    assert msg.point_step == 16 and msg.width == 3 and len(msg.data) == 48
    cloud = ros_io.read_landmark_cloud(msg)
    np.testing.assert_allclose(np.column_stack([cloud.x, cloud.y]), points)
    np.testing.assert_array_equal(cloud.ids, [4, -1, 12])


def test_cloud_without_id_field_and_float64_big_endian_with_row_padding():
    data = np.zeros((2, 3), dtype=[("y", ">f8"), ("x", ">f8"), ("pad", "V4")])  # 2 rows of 3
    data["x"] = [[1, 2, 3], [4, 5, 6]]
    data["y"] = [[-1, -2, -3], [-4, -5, -6]]
    rows = [row.tobytes() + b"\0" * 8 for row in data]  # each row padded by 8 bytes
    msg = PointCloud2(height=2, width=3, is_bigendian=True, point_step=20, row_step=68,
                      fields=[field("y", 0, PointField.FLOAT64), field("x", 8, PointField.FLOAT64)],
                      data=b"".join(rows))
    cloud = ros_io.read_landmark_cloud(msg)
    np.testing.assert_allclose(cloud.x, [1, 2, 3, 4, 5, 6])
    np.testing.assert_allclose(cloud.y, [-1, -2, -3, -4, -5, -6])
    assert cloud.ids is None


def test_cloud_with_numpy_data_as_rosbags_gives_it():
    msg = ros_io.landmark_cloud(HEADER, np.array([[3.0, 4.0]]), np.array([2]))
    look_alike = SimpleNamespace(fields=msg.fields, width=1, height=1, point_step=16, row_step=16,
                                 is_bigendian=False, data=np.frombuffer(bytes(msg.data), np.uint8))
    cloud = ros_io.read_landmark_cloud(look_alike)
    assert (cloud.x[0], cloud.y[0], cloud.ids[0]) == (3.0, 4.0, 2)


def test_empty_cloud_is_valid():
    cloud = ros_io.read_landmark_cloud(ros_io.landmark_cloud(HEADER, np.zeros((0, 2))))
    assert cloud.x.size == 0 and cloud.ids.size == 0


def malformed_clouds():
    good = ros_io.landmark_cloud(HEADER, np.array([[1.0, 2.0], [3.0, 4.0]]))
    def variant(**changes):
        msg = ros_io.landmark_cloud(HEADER, np.array([[1.0, 2.0], [3.0, 4.0]]))
        for name, value in changes.items():
            setattr(msg, name, value)
        return msg
    return {
        "no y field": variant(fields=[f for f in good.fields if f.name != "y"]),
        "x is int": variant(fields=[field("x", 0, PointField.INT32), *good.fields[1:]]),
        "id is float": variant(fields=[*good.fields[:3], field("id", 12, PointField.FLOAT32)]),
        "point_step too small": variant(point_step=12, row_step=24),
        "data too short": variant(data=bytes(good.data)[:20]),
        "data too long": variant(data=bytes(good.data) + b"\0" * 16),
        "row_step too small": variant(row_step=16),
    }


@pytest.mark.parametrize("case", sorted(malformed_clouds()))
def test_malformed_cloud_raises(case):
    with pytest.raises(ros_io.MalformedCloudError):
        ros_io.read_landmark_cloud(malformed_clouds()[case])


def test_map_cloud_layout_and_values():
    landmark_map = example_map()
    msg = ros_io.map_cloud(HEADER, landmark_map)
    assert [f.name for f in msg.fields] == ["x", "y", "z", "id", "cov_xx", "cov_xy", "cov_yy",
                                            "existence"]
    types = {f.name: f.datatype for f in msg.fields}
    assert types["id"] == PointField.INT32
    assert all(t == PointField.FLOAT32 for n, t in types.items() if n != "id")
    points = np.frombuffer(bytes(msg.data), ros_io.MAP_CLOUD_DTYPE)
    np.testing.assert_allclose(points["x"], landmark_map.means[:, 0])
    np.testing.assert_array_equal(points["id"], landmark_map.ids)
    np.testing.assert_allclose(points["cov_xy"], landmark_map.covariances[:, 0, 1], rtol=1e-6)
    np.testing.assert_allclose(points["existence"], landmark_map.existence, rtol=1e-6)
    assert msg.header.frame_id == "map" and msg.width == 3


def test_pose_with_covariance_uses_ros_6x6_layout():
    covariance = np.array([[1.0, 0.1, 0.2], [0.1, 2.0, 0.3], [0.2, 0.3, 3.0]])
    msg = ros_io.pose_with_covariance(HEADER, (1.0, 2.0, 0.5), covariance)
    full = np.array(msg.pose.covariance).reshape(6, 6)
    np.testing.assert_allclose(full[np.ix_([0, 1, 5], [0, 1, 5])], covariance)
    assert full[2, 2] == 0.0 and full[3, 3] == 0.0
    assert msg.pose.pose.position.x == 1.0
    assert ros_io.quaternion_to_yaw(msg.pose.pose.orientation) == pytest.approx(0.5)


def test_ellipse_axes_are_two_sigma_diameters_along_eigenvectors():
    major, minor, angle = geometry.ellipse_axes(example_map().covariances)
    assert (major[0], minor[0]) == pytest.approx((8.0, 4.0))  # 2 * 2 sigma, sigma = 2 and 1
    assert math.sin(angle[0]) == pytest.approx(0.0, abs=1e-12)
    assert (major[1], minor[1]) == pytest.approx((1.2, 0.4))
    assert math.tan(angle[1]) == pytest.approx(math.tan(0.5))


def test_landmark_markers_ellipse_label_and_delete_per_key():
    landmark_map = example_map()
    markers = ros_markers.landmark_markers(HEADER, landmark_map, removed_keys=[5]).markers
    ellipses = [m for m in markers
                if m.ns == ros_markers.ELLIPSE_NAMESPACE and m.action == Marker.ADD]
    labels = [m for m in markers if m.type == Marker.TEXT_VIEW_FACING]
    deletes = [m for m in markers if m.action == Marker.DELETE]
    assert [m.id for m in ellipses] == [0, 4, 9]
    assert all(m.type == Marker.CYLINDER for m in ellipses)
    assert [m.text for m in labels] == ["7", "k4", "3"]
    assert {(m.ns, m.id) for m in deletes} == {(ros_markers.LABEL_NAMESPACE, 5),
                                               (ros_markers.ELLIPSE_NAMESPACE, 5)}
    assert ellipses[0].scale.x == pytest.approx(8.0) and ellipses[0].scale.y == pytest.approx(4.0)
    assert ellipses[1].pose.position.x == -3.0 and ellipses[0].header.frame_id == "map"


def test_path_pose_array_and_transform():
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 1.0]])
    path = ros_io.path(HEADER, np.array([1.0, 2.5]), poses)
    assert len(path.poses) == 2 and ros_io.stamp_to_seconds(path.poses[1].header.stamp) == 2.5
    assert path.poses[1].pose.position.y == 0.5
    array = ros_io.pose_array(HEADER, poses)
    assert ros_io.quaternion_to_yaw(array.poses[1].orientation) == pytest.approx(1.0)
    transform = ros_io.transform(HEADER, "odom", (1.0, -1.0, -0.5))
    assert transform.child_frame_id == "odom" and transform.transform.translation.y == -1.0
    assert ros_io.quaternion_to_yaw(transform.transform.rotation) == pytest.approx(-0.5)


def test_write_map_file_yaml_reads_back(tmp_path):
    yaml = pytest.importorskip("yaml")
    landmark_map = example_map()
    landmark_map.covariances[2] = np.diag([1e-5, 2e-5])  # exponent floats stay floats in YAML 1.1
    written = map_files.write_map_file(tmp_path / "map.yaml", landmark_map, "map", 12.5)
    content = yaml.safe_load(written.read_text())
    assert content["frame_id"] == "map" and content["count"] == 3
    rows = content["landmarks"]
    assert [row["id"] for row in rows] == [7, -1, 3] and [row["key"] for row in rows] == [0, 4, 9]
    assert rows[2]["cov_xx"] == pytest.approx(1e-5) and isinstance(rows[2]["cov_yy"], float)
    assert rows[1]["x"] == -3.0 and rows[0]["existence"] == pytest.approx(0.9)


def test_write_map_file_csv(tmp_path):
    written = map_files.write_map_file(tmp_path / "map.csv", example_map(), "map", 0.0)
    with written.open() as stream:
        rows = list(csv.DictReader(stream))
    assert list(rows[0]) == list(map_files.MAP_FILE_COLUMNS)
    assert [int(r["id"]) for r in rows] == [7, -1, 3]
    assert float(rows[0]["cov_xx"]) == 4.0 and float(rows[2]["y"]) == -4.0


def test_write_map_file_empty_map_is_valid_yaml(tmp_path):
    yaml = pytest.importorskip("yaml")
    empty = SimpleNamespace(means=np.zeros((0, 2)), covariances=np.zeros((0, 2, 2)),
                            existence=np.zeros(0), ids=np.zeros(0, np.int64),
                            keys=np.zeros(0, np.int64))
    written = map_files.write_map_file(tmp_path / "empty.yaml", empty, "map", 1.0)
    assert yaml.safe_load(written.read_text())["landmarks"] == []


def test_path_builder_reuses_unchanged_poses_and_follows_changes():
    builder = ros_io.PathBuilder()
    first = builder.build(HEADER, np.array([1.0, 2.0]),
                          np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.5]]))
    second = builder.build(HEADER, np.array([1.0, 2.0, 3.0]),
                           np.array([[0.0, 0.0, 0.0], [1.0, 0.1, 0.5], [2.0, 0.0, 1.0]]))
    assert second.poses[0] is first.poses[0]  # same stamp and pose: reused
    assert second.poses[1] is not first.poses[1] and second.poses[1].pose.position.y == 0.1
    assert [ros_io.stamp_to_seconds(p.header.stamp) for p in second.poses] == [1.0, 2.0, 3.0]


def test_marker_builder_rebuilds_only_changed_landmarks():
    builder = ros_markers.MarkerBuilder()
    landmark_map = example_map()
    first = builder.build(HEADER, landmark_map).markers
    assert [m.id for m in first] == [0, 0, 4, 4, 9, 9]
    reference = ros_markers.landmark_markers(HEADER, landmark_map).markers
    assert [(m.pose.position.x, m.scale.x, m.text) for m in first] == \
        [(m.pose.position.x, m.scale.x, m.text) for m in reference]
    landmark_map.means[1] += 0.5
    second = builder.build(HEADER, landmark_map, removed_keys=[12]).markers
    assert second[0] is first[0] and second[5] is first[5]     # unchanged: reused
    assert second[2] is not first[2] and second[2].pose.position.x == -2.5
    assert [m.action for m in second[6:]] == [Marker.DELETE, Marker.DELETE]


def test_path_history_chain_is_bounded_and_keeps_the_recent_path():
    from fastslam_ros.core.path_history import PathHistory
    history = PathHistory(num_particles=3, prune_every=4, chain_capacity=64)
    for step in range(1000):
        history.record(float(step), np.full((3, 3), float(step)))
        history.resample(np.zeros(3, np.int64))  # all particles descend from one
    stamps, poses = history.path(0)
    assert len(stamps) <= 64 + 2 * 4 * 2 and np.all(np.diff(stamps) > 0)
    assert stamps[-1] == 999.0 and stamps[0] == 0.0
    np.testing.assert_array_equal(stamps[-20:], np.arange(980.0, 1000.0))
    np.testing.assert_array_equal(poses[:, 0], stamps)


def test_path_decimation_is_bounded_even_and_stable():
    from fastslam_ros.node import decimation
    assert decimation(10, 10) is None
    for length in (101, 1000, 4097, 123_457):
        keep = decimation(length, 100)
        assert len(keep) <= 100 and keep[0] == 0 and keep[-1] == length - 1
        assert np.all(np.diff(keep) > 0)
    longer = decimation(1100, 100)
    assert set(decimation(1000, 100)[:-1]) <= set(longer)  # kept poses stay kept as it grows


def test_input_rate_counts_lost_messages_not_jitter_or_bursts():
    from fastslam_ros.node_support.timing import InputRate
    rate = InputRate()
    stamps = list(np.arange(0.0, 2.0, 0.01))
    del stamps[100:110]                                   # ten lost at 1.0 s
    del stamps[150:151]                                   # one lost: as long as jitter, not counted
    stamps += [2.0, 2.035, 2.036, 2.037, 2.04, 2.05]      # late, then catching up: none lost
    for stamp in stamps:
        rate.record(stamp, stamp)
    assert rate.interval == pytest.approx(0.01, rel=0.05)
    assert rate.missing == 10 and rate.largest_gap == pytest.approx(0.11)
    assert rate.silence(2.06) == 0.0 and rate.silence(3.5) == pytest.approx(1.45)


def scan_like(count: int = 5, increment: float = 0.1, **fields) -> SimpleNamespace:
    """A LaserScan's fields, consistent unless ``fields`` says otherwise."""
    values = dict(ranges=[1.0] * count, angle_min=-0.2, angle_increment=increment,
                  angle_max=-0.2 + (count - 1) * increment, range_min=0.1, range_max=10.0,
                  time_increment=0.0)
    return SimpleNamespace(**{**values, **fields})


@pytest.mark.parametrize("angle_max_beams", [4.0, 4.4, 3.6, 5.0, 5.4])
def test_scan_geometry_takes_angle_max_at_the_last_beam_or_one_beyond(angle_max_beams):
    # REP 117 puts angle_max at the last beam (n - 1 increments); pointcloud_to_laserscan one
    # increment beyond; half an increment of float32 rounding either way.
    geometry = ros_io.scan_geometry(scan_like(angle_max=-0.2 + angle_max_beams * 0.1))
    assert geometry.count == 5 and geometry.angle_increment == 0.1


@pytest.mark.parametrize("fields, words", [
    ({"ranges": []}, "no beams"),
    ({"angle_increment": 0.0}, "unusable"),
    ({"angle_increment": math.nan}, "unusable"),
    ({"angle_max": -0.2 + 3.4 * 0.1}, "angle_max"),
    ({"angle_max": -0.2 + 5.6 * 0.1}, "angle_max"),
    ({"range_min": math.nan}, "range_min"),
    ({"range_max": math.nan}, "range_max"),
    ({"range_min": math.inf}, "range_min"),
    ({"range_min": 5.0, "range_max": 1.0}, "range_max"),
    ({"time_increment": math.inf}, "time_increment"),
])
def test_scan_geometry_names_what_makes_a_scan_malformed(fields, words):
    with pytest.raises(ros_io.MalformedScanError, match=words):
        ros_io.scan_geometry(scan_like(**fields))


def test_scan_geometry_caps_beams_before_reading_them_and_normalizes_the_limits():
    with pytest.raises(ros_io.OversizedError, match="max_beams_per_scan 4"):
        ros_io.scan_geometry(scan_like(), max_beams=4)
    turn = 2.0 * math.pi / 4
    with pytest.raises(ros_io.MalformedScanError, match="more than a turn"):
        ros_io.scan_geometry(scan_like(count=6, increment=turn))
    geometry = ros_io.scan_geometry(scan_like(range_min=-1.0, range_max=0.0), max_beams=5)
    assert geometry.range_min == 0.0 and geometry.range_max == math.inf   # 0: left unset
    reversed_scan = ros_io.scan_geometry(scan_like(angle_min=0.2, angle_increment=-0.1,
                                                   angle_max=-0.2))
    assert reversed_scan.angle_increment == -0.1
