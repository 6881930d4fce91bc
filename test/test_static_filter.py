# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""StaticFilter (extractor.static_filter) on closed-form geometry: a pole seen from a moving,
turning robot passes, a walker and a person turning round do not, nothing passes before a
window's worth of history; and the extractor node with the filter on: odometry gives each
scan's pose, a scan that no odometry covers is dropped and counted."""
from __future__ import annotations

import math

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from std_msgs.msg import Header

from fastslam_ros import ros_io
from fastslam_ros.extractor.static_filter import StaticFilter, to_frame
from fastslam_ros.node_parameters import ParameterError

RATE = 10.0  # scans per second
WINDOW = 0.5
TOLERANCE = 0.3


def robot_pose(time: float) -> np.ndarray:
    """A robot driving 1 m/s on a circle of radius 5 m (turning 0.2 rad/s)."""
    angle = 0.2 * time
    return np.array([5.0 * math.sin(angle), 5.0 - 5.0 * math.cos(angle), angle])


def in_sensor_frame(pose: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World points (N, 2) as the sensor at ``pose`` sees them."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    dx, dy = points[:, 0] - pose[0], points[:, 1] - pose[1]
    return c * dx + s * dy, -s * dx + c * dy


def walker(time: float) -> np.ndarray:
    """A person walking 1.2 m/s along y at x = 3 m."""
    return np.array([3.0, -4.0 + 1.2 * time])


def run(objects, duration: float = 4.0):
    """(stamps, masks) of the filter over ``duration`` s of scans of ``objects(t)`` (N, 2)."""
    static = StaticFilter(WINDOW, TOLERANCE)
    stamps = np.arange(0.0, duration, 1.0 / RATE)
    masks = []
    for stamp in stamps:
        pose = robot_pose(stamp)
        masks.append(static.update(stamp, pose, *in_sensor_frame(pose, objects(stamp))))
    return stamps, np.array(masks)


def test_to_frame_is_the_inverse_of_the_sensor_view():
    pose = np.array([1.0, -2.0, 2.5])
    points = np.array([[3.0, 4.0], [-1.0, 0.5]])
    assert to_frame(pose, *in_sensor_frame(pose, points)) == pytest.approx(points)


def test_a_pole_passes_from_a_turning_robot_after_one_window_and_a_walker_never():
    pole = np.array([4.0, 2.0])
    stamps, masks = run(lambda t: np.array([pole, walker(t)]))
    settled = stamps >= WINDOW - 1e-9
    assert not masks[~settled].any()  # no scan a window older yet: nothing passes
    assert masks[settled, 0].all()
    assert not masks[:, 1].any()  # 0.6 m in 0.5 s, 0.3 m in 0.25 s: beyond the tolerance


@pytest.mark.parametrize("window, passing", [(0.5, True), (1.0, False)])
def test_a_person_turning_round(window, passing):
    """Walking to and fro (1.2 m/s, 1.4 m): a turn a seconds before the scan puts the person
    1.2 |window - 2 a| m from where it was window s earlier, and a single look lets it pass
    for 0.25 s each turn. The look at window / 2 as well stops it for any turn once
    1.2 window / 4 >= tolerance (window 1 s), not before (0.5 s: a in [0.125, 0.25] s)."""
    def pacing(t: float) -> np.ndarray:
        travelled = (1.2 * t) % 2.8
        return np.array([[3.0, travelled if travelled < 1.4 else 2.8 - travelled]])
    static = StaticFilter(window, TOLERANCE)
    masks = []
    for stamp in np.arange(0.0, 10.0, 0.01):
        pose = robot_pose(stamp)
        masks.append(static.update(stamp, pose, *in_sensor_frame(pose, pacing(stamp)))[0])
    assert any(masks) == passing


def test_odometry_drift_within_the_tolerance_passes_beyond_it_not():
    pole = np.array([[6.0, 1.0]])
    for drift, passes in ((0.1, True), (0.5, False)):
        static = StaticFilter(WINDOW, TOLERANCE)
        for stamp in np.arange(0.0, 2.0, 1.0 / RATE):
            pose = robot_pose(stamp)  # the true pose sees the pole ...
            odometry = pose + [drift / WINDOW * stamp, 0.0, 0.0]  # ... odometry drifts in x
            mask = static.update(stamp, odometry, *in_sensor_frame(pose, pole))
        assert mask[0] == passes, drift


def test_memory_is_bounded_by_the_window():
    static = StaticFilter(WINDOW, TOLERANCE)
    for stamp in np.arange(0.0, 60.0, 1.0 / RATE):
        static.update(stamp, np.zeros(3), np.ones(5), np.ones(5))
    assert len(static) <= WINDOW * RATE + 2


def test_time_going_back_starts_over():
    static = StaticFilter(WINDOW, TOLERANCE)
    for stamp in np.arange(0.0, 2.0, 1.0 / RATE):
        assert static.update(stamp, np.zeros(3), [2.0], [0.0])[0] == (stamp >= WINDOW - 1e-9)
    assert not static.update(0.0, np.zeros(3), [2.0], [0.0]).any()
    assert len(static) == 1


def test_an_empty_scan_and_an_empty_reference():
    static = StaticFilter(WINDOW, TOLERANCE)
    static.update(0.0, np.zeros(3), [], [])
    static.update(0.25, np.zeros(3), [2.0], [0.0])
    assert static.update(0.5, np.zeros(3), [2.0], [0.0]).shape == (1,)
    assert not static.update(0.5001, np.zeros(3), [2.0], [0.0]).any()  # reference 0.0 empty
    assert static.update(0.75, np.zeros(3), [], []).shape == (0,)


# --- the node ---------------------------------------------------------------------------------

def odometry_message(stamp: float, pose) -> Odometry:
    msg = Odometry(header=Header(stamp=ros_io.seconds_to_stamp(stamp), frame_id="odom"),
                   child_frame_id="base_link")
    msg.pose.pose = ros_io.pose_msg(tuple(pose))
    return msg


def test_node_rejects_a_bad_window(context):
    from test_landmark_extractor_node import make_node
    with pytest.raises(ParameterError, match="'static_window'"):
        make_node(context, static_window=-1.0)


def test_node_publishes_the_pole_not_the_walker_and_drops_scans_without_odometry(context):
    from test_extractor import cast
    from test_landmark_extractor_node import START, Recorder, deliver, make_node, scan_message
    node = make_node(context, static_window=0.45, sensor_x=0.2)
    recorder = Recorder(node)
    sensor = np.array([0.2, 0.0, 0.0])
    pole = np.array([[5.0, 3.0]])
    try:
        for step in range(30):
            t = step / RATE
            pose = robot_pose(t)  # base_link; the laser sits 0.2 m ahead
            deliver(node, odometry_message(START + t, pose), START + t)
            laser = pose + [0.2 * math.cos(pose[2]), 0.2 * math.sin(pose[2]), 0.0]
            x, y = in_sensor_frame(laser, np.vstack([pole, walker(t)]))
            before = len(recorder.messages.get("/landmarks", []))
            deliver(node, scan_message(START + t + 0.02,
                                       cast([(x[0], y[0], 0.15), (x[1], y[1], 0.2)])),
                    START + t + 0.02)
            assert len(recorder.messages.get("/landmarks", [])) == before  # waits for odom
        deliver(node, odometry_message(START + 3.0, robot_pose(3.0)), START + 3.0)
        clouds = recorder.messages["/landmarks"]
        assert len(clouds) == 30
        counts = [ros_io.read_landmark_cloud(c).x.size for c in clouds]
        settled = [step >= 5 for step in range(30)]  # a scan 0.45 s older exists
        assert counts == [1 if s else 0 for s in settled]
        stamp = clouds[-1].header.stamp
        last = ros_io.read_landmark_cloud(clouds[-1])
        laser = compose_pose(robot_pose(2.9), sensor)  # where that scan was cast from
        assert to_frame(laser, last.x, last.y)[0] == pytest.approx(pole[0], abs=0.01)
        assert stamp == scan_message(START + 2.9 + 0.02, []).header.stamp  # the scan's own
        assert node.stats["rejected_moving"] == 30 + sum(not s for s in settled)
        # A scan that no odometry covers: dropped and counted once max_observation_wait passed.
        deliver(node, scan_message(START + 3.5, cast([(4.0, 1.0, 0.15)])), START + 3.5)
        deliver(node, scan_message(START + 4.5, cast([(4.0, 1.0, 0.15)])), START + 4.5)
        assert len(recorder.messages["/landmarks"]) == 30
        assert node.stats["dropped_stale"] == 1
        node.flush()  # end of input: the queued scan is dropped as well
        assert node.stats["dropped_stale"] == 2
        assert len(recorder.messages["/landmarks"]) == 30
        assert "dropped" in recorder.last_status().message
    finally:
        node.destroy_node()


def compose_pose(pose: np.ndarray, offset: np.ndarray) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([pose[0] + c * offset[0] - s * offset[1],
                     pose[1] + s * offset[0] + c * offset[1], pose[2] + offset[2]])
