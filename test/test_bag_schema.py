# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Bag schema v1: round trips through MCAP and sqlite3, position-only truth, cloud layouts."""
from __future__ import annotations

import numpy as np
import pytest

from fastslam_ros.tools.bags.bag_schema import (CLOUD_TYPE, GROUND_TRUTH_POSE_TOPIC,
                                                TF_STATIC_TOPIC, TYPESTORE, LandmarkScans,
                                                LandmarkSet, PoseSeries, SchemaBag, SchemaError,
                                                bag_topics, landmark_cloud_arrays, ns_to_stamp,
                                                read_last, read_schema_bag, read_topic, stamp_to_ns,
                                                write_schema_bag)
from fastslam_ros.tools.simulation.sim import SimConfig, simulate


@pytest.fixture(scope="module")
def simulated() -> SchemaBag:
    return simulate(SimConfig(duration=15.0, seed=3))


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_simulated_bag_round_trips(tmp_path, simulated, storage):
    path = write_schema_bag(tmp_path / "bag", simulated, storage=storage)
    back = read_schema_bag(path)

    np.testing.assert_array_equal(back.odometry.stamps, simulated.odometry.stamps)
    np.testing.assert_array_equal(back.odometry.poses[:, :2], simulated.odometry.poses[:, :2])
    # theta goes through a quaternion: equal up to rounding of sin/cos/atan2.
    np.testing.assert_allclose(back.odometry.poses[:, 2], simulated.odometry.poses[:, 2],
                               rtol=0, atol=1e-14)
    np.testing.assert_array_equal(back.ground_truth.poses[:, :2],
                                  simulated.ground_truth.poses[:, :2])
    assert (back.odometry.frame_id, back.odometry.child_frame_id) == ("odom", "base_link")
    assert back.ground_truth.frame_id == "map" and not back.ground_truth.position_only
    np.testing.assert_array_equal(back.scans.stamps, simulated.scans.stamps)
    assert back.scans.frame_id == simulated.scans.frame_id
    assert len(back.scans.points) == len(simulated.scans.points)
    for read_points, points, read_ids, ids in zip(back.scans.points, simulated.scans.points,
                                                  back.scans.ids, simulated.scans.ids):
        np.testing.assert_array_equal(read_points, points.astype(np.float32))
        np.testing.assert_array_equal(read_ids, ids)
    np.testing.assert_array_equal(back.landmarks_truth.ids, simulated.landmarks_truth.ids)
    np.testing.assert_array_equal(back.landmarks_truth.positions,
                                  simulated.landmarks_truth.positions.astype(np.float32))


def test_messages_are_logged_at_their_header_stamps_in_time_order(tmp_path, simulated):
    path = write_schema_bag(tmp_path / "bag", simulated)
    log_stamps, messages = read_topic(path, "/landmarks")
    header_stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in messages]
    np.testing.assert_allclose(log_stamps, header_stamps, rtol=0, atol=1e-9)
    assert np.all(np.diff(log_stamps) > 0)
    assert set(bag_topics(path)) == {"/odom", "/landmarks", "/ground_truth/pose",
                                     "/ground_truth/landmarks"}


def test_position_only_ground_truth_is_flagged_and_has_no_heading(tmp_path):
    stamps = np.array([0.0, 0.5, 1.0])
    poses = np.array([[0.0, 0.0, 0.3], [1.0, 0.5, 0.3], [2.0, 1.0, 0.3]])
    bag = SchemaBag(PoseSeries(stamps, poses), LandmarkScans(stamps, [np.zeros((0, 2))] * 3,
                                                              [np.zeros(0, np.int32)] * 3),
                    ground_truth=PoseSeries(stamps, poses, "map", position_only=True))
    path = write_schema_bag(tmp_path / "gps", bag)

    _, messages = read_topic(path, GROUND_TRUTH_POSE_TOPIC)
    orientation = messages[0].pose.pose.orientation
    assert (orientation.x, orientation.y, orientation.z, orientation.w) == (0.0, 0.0, 0.0, 1.0)
    assert messages[0].pose.covariance[35] == -1.0
    back = read_schema_bag(path)
    assert back.ground_truth.position_only
    np.testing.assert_array_equal(back.ground_truth.poses[:, :2], poses[:, :2])
    assert np.all(np.isnan(back.ground_truth.poses[:, 2]))
    assert back.landmarks_truth is None
    assert all(len(points) == 0 for points in back.scans.points)


def test_reference_point_of_the_ground_truth_round_trips_as_a_static_transform(tmp_path):
    stamps = np.array([0.0, 0.5, 1.0])
    poses = np.array([[0.0, 0.0, 0.3], [1.0, 0.5, 0.3], [2.0, 1.0, 0.3]])
    truth = PoseSeries(stamps, poses, "map", "gps_antenna", position_only=True,
                       reference_offset=np.array([3.7, 1.0]))
    bag = SchemaBag(PoseSeries(stamps, poses), LandmarkScans(stamps, [np.zeros((0, 2))] * 3,
                                                              [np.zeros(0, np.int32)] * 3),
                    ground_truth=truth)
    path = write_schema_bag(tmp_path / "antenna", bag)
    _, messages = read_topic(path, TF_STATIC_TOPIC)
    transform = messages[0].transforms[0]
    assert (transform.header.frame_id, transform.child_frame_id) == ("base_link", "gps_antenna")
    assert (transform.transform.translation.x, transform.transform.translation.y) == (3.7, 1.0)
    back = read_schema_bag(path)
    assert back.ground_truth.child_frame_id == "gps_antenna"
    np.testing.assert_array_equal(back.ground_truth.reference_offset, [3.7, 1.0])
    # Without an offset there is no /tf_static and the reference is the base.
    bag.ground_truth = PoseSeries(stamps, poses, "map", position_only=True)
    back = read_schema_bag(write_schema_bag(tmp_path / "base", bag))
    assert back.ground_truth.reference_offset is None


def test_missing_input_topic_is_named(tmp_path):
    stamps = np.array([0.0, 1.0])
    bag = SchemaBag(PoseSeries(stamps, np.zeros((2, 3))), LandmarkScans(np.zeros(0), [], []))
    path = write_schema_bag(tmp_path / "odom_only", bag)
    with pytest.raises(SchemaError, match="/landmarks"):
        read_schema_bag(path)
    assert len(read_schema_bag(path, require_inputs=False).odometry.stamps) == 2
    with pytest.raises(FileNotFoundError):
        read_schema_bag(tmp_path / "absent")


def test_existing_output_is_kept_unless_overwrite(tmp_path, simulated):
    path = write_schema_bag(tmp_path / "bag", simulated)
    with pytest.raises(FileExistsError):
        write_schema_bag(path, simulated)
    write_schema_bag(path, simulated, overwrite=True)
    assert read_last(path, ["/odom"])["/odom"][0] == pytest.approx(simulated.odometry.stamps[-1])


def test_cloud_without_id_field_reads_as_unknown_ids():
    types = TYPESTORE.types
    field = types["sensor_msgs/msg/PointField"]
    data = np.array([[1.0, 2.0], [3.0, -4.0]], dtype="<f4")
    msg = types[CLOUD_TYPE](
        header=types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="laser"),
        height=1, width=2,
        fields=[field(name="x", offset=0, datatype=7, count=1),
                field(name="y", offset=4, datatype=7, count=1)],
        is_bigendian=False, point_step=8, row_step=16, data=data.view(np.uint8).reshape(-1),
        is_dense=True)
    points, ids = landmark_cloud_arrays(msg)
    np.testing.assert_array_equal(points, data)
    np.testing.assert_array_equal(ids, [-1, -1])


def test_stamp_conversion_keeps_nanoseconds():
    assert stamp_to_ns(1.5) == 1_500_000_000
    assert stamp_to_ns(0.025) == 25_000_000
    epoch = 1248272263.127  # a double resolves ~240 ns here: within that, and back exactly
    assert abs(stamp_to_ns(epoch) - 1_248_272_263_127_000_000) <= 120
    assert ns_to_stamp(stamp_to_ns(epoch)) == epoch
    assert ns_to_stamp(1_500_000_000) == 1.5


def test_landmark_set_positions_are_written_in_map_frame(tmp_path):
    stamps = np.array([0.0])
    truth = LandmarkSet(np.array([[5.0, 6.0], [-1.0, 2.5]]), np.array([7, 9], dtype=np.int32))
    bag = SchemaBag(PoseSeries(stamps, np.zeros((1, 3))),
                    LandmarkScans(stamps, [np.zeros((0, 2))], [np.zeros(0, np.int32)]),
                    landmarks_truth=truth)
    path = write_schema_bag(tmp_path / "truth", bag)
    _, messages = read_topic(path, "/ground_truth/landmarks")
    assert len(messages) == 1 and messages[0].header.frame_id == "map"
    back = read_schema_bag(path).landmarks_truth
    np.testing.assert_array_equal(back.positions, truth.positions)
    np.testing.assert_array_equal(back.ids, truth.ids)
