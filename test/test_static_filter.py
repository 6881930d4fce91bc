# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""StaticFilter (extractor.static_filter) on closed-form geometry: a pole seen from a moving,
turning robot always passes (also when a scan missed it or a walker hid it), a walker whose
place an earlier scan saw empty does not, nothing is dropped before there is a reference scan;
and the extractor node with the filter on: odometry gives each scan's pose, a scan that no
odometry covers is dropped and counted."""
from __future__ import annotations

import math

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from std_msgs.msg import Header

from fastslam_ros import ros_io
from fastslam_ros.extractor.scan import RawScan
from fastslam_ros.extractor.static_filter import StaticFilter, free_reach, from_frame, to_frame
from fastslam_ros.node_parameters import ParameterError
from test_extractor import ANGLE_MIN, INCREMENT, cast

RATE = 10.0  # scans per second
WINDOW = 0.5
TOLERANCE = 0.3
POLE_RADIUS = 0.1
WALKER_RADIUS = 0.2


def robot_pose(time: float) -> np.ndarray:
    """A robot driving 1 m/s on a circle of radius 5 m (turning 0.2 rad/s)."""
    angle = 0.2 * time
    return np.array([5.0 * math.sin(angle), 5.0 - 5.0 * math.cos(angle), angle])


def in_sensor_frame(pose: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World points (N, 2) as the sensor at ``pose`` sees them."""
    return from_frame(pose, np.asarray(points, float))


def walker(time: float) -> np.ndarray:
    """A person crossing the robot's way 1.2 m/s, 12 m ahead (sideways to the line of
    sight: a person walking straight at the sensor is not told from a pole)."""
    return np.array([12.0, -2.0 + 1.2 * time])


def scan_of(pose: np.ndarray, centres: np.ndarray, radii) -> RawScan:
    """The noiseless scan of circles (world frame) from ``pose`` (a wall far behind)."""
    x, y = in_sensor_frame(pose, centres)
    return RawScan(cast(list(zip(x, y, radii))), ANGLE_MIN, INCREMENT, 0.05, 30.0)


def run(objects, radii, detect=None, duration: float = 4.0, window: float = WINDOW):
    """(stamps, masks) over ``duration`` s of scans of ``objects(t)`` (N, 2) whose detections
    are the objects ``detect(step)`` (N,) (all by default)."""
    static = StaticFilter(window, TOLERANCE)
    stamps = np.arange(0.0, duration, 1.0 / RATE)
    masks = []
    for step, stamp in enumerate(stamps):
        pose, centres = robot_pose(stamp), objects(stamp)
        seen = np.ones(len(centres), bool) if detect is None else detect(step)
        x, y = in_sensor_frame(pose, centres[seen])
        mask = np.zeros(len(centres), bool)
        mask[seen] = static.update(stamp, pose, x, y, scan_of(pose, centres, radii))
        masks.append(mask)
    return stamps, np.array(masks)


def test_frames_and_free_reach():
    pose = np.array([1.0, -2.0, 2.5])
    points = np.array([[3.0, 4.0], [-1.0, 0.5]])
    assert to_frame(pose, *in_sensor_frame(pose, points)) == pytest.approx(points)
    scan = RawScan(np.array([1.0, np.inf, np.nan, 0.01, 30.0, -np.inf]), 0.0, 0.1, 0.05, 30.0)
    assert free_reach(scan).tolist() == [1.0, 30.0, -np.inf, -np.inf, 30.0, -np.inf]


def test_a_pole_always_passes_a_walker_after_one_window():
    pole = np.array([4.0, 2.0])
    stamps, masks = run(lambda t: np.array([pole, walker(t)]), [POLE_RADIUS, WALKER_RADIUS])
    assert masks[:, 0].all()
    first = stamps < WINDOW / 2 - 1e-9  # no reference scan yet: no evidence
    assert masks[first, 1].all()
    # 0.6 m in 0.5 s: the walker's place was seen empty (its body 0.4 m from the disc's
    # centre, beyond the 0.3 m tolerance) once the reference 0.5 s back exists.
    assert not masks[stamps >= WINDOW - 1e-9, 1].any()


def test_a_pole_missed_or_hidden_in_the_reference_scans_still_passes():
    pole = np.array([4.0, 2.0])
    # Detected in every third scan only (a flickering far pole): never dropped.
    _, masks = run(lambda t: np.array([pole]), [POLE_RADIUS],
                   detect=lambda step: np.array([step % 3 == 0]))
    assert masks[::3, 0].all()
    # Hidden now and then by a person passing in front: still never dropped.
    def crossing(t: float) -> np.ndarray:
        return np.array([pole, [2.0, -3.0 + 2.0 * t]])
    _, masks = run(crossing, [POLE_RADIUS, WALKER_RADIUS],
                   detect=lambda step: np.array([True, False]))
    assert masks[:, 0].all()


@pytest.mark.parametrize("speed", [1.2, -1.2])
def test_a_walker_going_straight_away_or_towards_the_sensor_is_dropped(speed):
    """Walking along the line of sight, the person hides (or nearly fills) its own earlier
    place: no scan sees it empty, but the earlier detection 0.6 m away, beyond the tolerance
    and within it plus 2 m/s x 0.5 s, is the same person moved."""
    static = StaticFilter(WINDOW, TOLERANCE)
    kept = []
    for stamp in np.arange(0.0, 3.0, 1.0 / RATE):
        pose = np.zeros(3)
        centres = np.array([[6.0 + speed * stamp, 0.5]])
        kept.append(static.update(stamp, pose, *in_sensor_frame(pose, centres),
                                  scan_of(pose, centres, [WALKER_RADIUS]))[0])
    assert all(kept[:3]) and not any(kept[3:])  # the reference 0.25 s back: 0.3 m


@pytest.mark.parametrize("window", [0.5, 1.0])
def test_a_person_turning_round_is_kept_only_near_the_turns(window):
    """Pacing to and fro (1.2 m/s, 1.4 m) sideways, 8 m ahead of a robot standing still: while
    walking straight for a window the person's place was seen empty (the body moved 1.2 x
    window >= 0.6 m, beyond tolerance + body radius); within a window of a turn it may stand
    where the reference scans saw it."""
    def pacing(t: float) -> np.ndarray:
        travelled = (1.2 * t) % 2.8
        return np.array([[8.0, -0.7 + (travelled if travelled < 1.4 else 2.8 - travelled)]])
    static = StaticFilter(window, TOLERANCE)
    stamps = np.arange(0.0, 10.0, 0.01)
    kept = []
    for stamp in stamps:
        pose = np.zeros(3)
        centres = pacing(stamp)
        kept.append(static.update(stamp, pose, *in_sensor_frame(pose, centres),
                                  scan_of(pose, centres, [WALKER_RADIUS]))[0])
    kept = np.array(kept)[stamps >= window]
    turns = np.arange(1.4 / 1.2, 10.0, 1.4 / 1.2)
    near_turn = (np.abs(stamps[stamps >= window, None] - turns[None, :]) <= window).any(axis=1)
    assert not kept[~near_turn].any()
    assert kept.mean() < 0.5


def test_odometry_heading_error_and_the_heading_tolerance():
    """A thin post 20 m away seen with a heading error of 0.02 rad (0.4 m at its range): the
    disc of 0.3 m around it looks empty; 0.3 m + 0.01 x 20 m covers it."""
    post = np.array([[20.0, 0.0]])
    for heading_tolerance, passes in ((0.0, False), (0.01, True)):
        static = StaticFilter(WINDOW, TOLERANCE, heading_tolerance)
        for stamp in np.arange(0.0, 1.0, 1.0 / RATE):
            true = np.array([1.0 * stamp, 0.0, 0.0])
            odometry = true + [0.0, 0.0, 0.02 * stamp / WINDOW]  # heading drifts
            mask = static.update(stamp, odometry, *in_sensor_frame(true, post),
                                 scan_of(true, post, [0.05]))
        assert mask[0] == passes, heading_tolerance


def test_out_of_view_is_no_evidence():
    """A pole behind the robot in the reference scan (outside the 270-degree opening), in
    view now: kept."""
    static = StaticFilter(WINDOW, TOLERANCE)
    pole = np.array([[-3.0, 0.0]])
    for stamp, yaw in ((0.0, 0.0), (0.6, math.pi)):
        pose = np.array([0.0, 0.0, yaw])
        mask = static.update(stamp, pose, *in_sensor_frame(pose, pole),
                             scan_of(pose, pole, [POLE_RADIUS]))
    assert mask.tolist() == [True]


def test_memory_is_bounded_by_the_window():
    static = StaticFilter(WINDOW, TOLERANCE)
    scan = scan_of(np.zeros(3), np.zeros((0, 2)), [])
    for stamp in np.arange(0.0, 60.0, 1.0 / RATE):
        static.update(stamp, np.zeros(3), np.ones(5), np.ones(5), scan)
    assert len(static) <= WINDOW * RATE + 2


def test_time_going_back_starts_over():
    static = StaticFilter(WINDOW, TOLERANCE)
    empty = scan_of(np.zeros(3), np.zeros((0, 2)), [])
    for stamp in np.arange(0.0, 2.0, 1.0 / RATE):  # an empty world: a detection is moving
        kept = static.update(stamp, np.zeros(3), [2.0], [0.0], empty)[0]
        assert kept == (stamp < WINDOW / 2 - 1e-9)
    assert static.update(0.0, np.zeros(3), [2.0], [0.0], empty).all()
    assert len(static) == 1
    assert static.update(0.5, np.zeros(3), [], [], empty).shape == (0,)


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
        # No reference scan 0.225 s back before the fourth scan: both kept; once the one
        # 0.45 s back exists, the walker's place was seen empty: the pole alone.
        assert counts[:3] == [2, 2, 2] and counts[5:] == [1] * 25
        stamp = clouds[-1].header.stamp
        last = ros_io.read_landmark_cloud(clouds[-1])
        laser = compose_pose(robot_pose(2.9), sensor)  # where that scan was cast from
        assert to_frame(laser, last.x, last.y)[0] == pytest.approx(pole[0], abs=0.01)
        assert stamp == scan_message(START + 2.9 + 0.02, []).header.stamp  # the scan's own
        assert node.stats["rejected_moving"] == 60 - sum(counts)
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
