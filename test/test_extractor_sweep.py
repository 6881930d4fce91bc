# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A laser that sweeps while the robot drives and turns: the extractor's landmarks brought back
to the first beam's pose (``Landmarks.at_first_beam``, the node's ``deskew_scans``) against
the true poles, in the core and through the node with odometry; without odometry the node
publishes them as seen and says so."""
from __future__ import annotations

import math

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import LaserScan

from fastslam_ros import ros_io
from fastslam_ros.core.geometry import relative_pose
from fastslam_ros.core.sweep import STILL, at_beam_time, at_first_beam
from fastslam_ros.extractor import ExtractorSettings, RawScan, extract_landmarks
from fastslam_ros.extractor.static_filter import StaticFilter
from fastslam_ros.extractor_io import read_scan
from fastslam_ros.ros_io import MalformedScanError
from fastslam_ros.tools.simulation.laser_sim import Laser, PoleWorld
from fastslam_ros.tools.simulation.people_sim import sweep_poses, sweep_time_increment
from test_landmark_extractor_node import START, Recorder, deliver, make_node
from test_static_filter import odometry_message

LASER = Laser(beams=541, max_range=20.0)
RATE = 5.0                    # scans per second: a full turn of the mirror takes 0.2 s
SPEED, TURN = 3.0, 0.5        # m/s, rad/s
POLES = PoleWorld(np.array([[8.0, 3.0], [12.0, -4.0], [5.0, 6.0], [15.0, 2.0], [-3.0, 6.0]]),
                  np.full(5, 0.15), np.zeros(5, bool), np.zeros((0, 4)))
TIME_INCREMENT = sweep_time_increment(LASER.angles[1] - LASER.angles[0], RATE)


def truth(t: float) -> np.ndarray:
    """The robot's pose t s into an arc from the origin (a unicycle: exact)."""
    return sweep_poses(np.zeros(3), SPEED, TURN, 2, t)[1]


def swept_ranges(t: float) -> np.ndarray:
    """The noise-free scan whose first beam is taken at t, each beam from the pose of its time."""
    return LASER.cast(POLES, sweep_poses(truth(t), SPEED, TURN, LASER.beams, TIME_INCREMENT))[0]


def pole_errors(x: np.ndarray, y: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Distance (m) of each landmark (sensor frame at ``pose``) to the nearest true pole."""
    seen = np.array([relative_pose(pose, np.append(c, 0.0))[:2] for c in POLES.centres])
    return np.min(np.hypot(x[:, None] - seen[:, 0], y[:, None] - seen[:, 1]), axis=1)


def test_landmarks_of_a_swept_scan_come_back_to_the_first_beams_pose():
    """Driving at 3 m/s and turning at 0.5 rad/s over a 0.15 s sweep, the poles are extracted
    up to 0.6 m from where the laser at its first beam sees them; brought back at the true
    motion, within 2 cm (the first-order error over the sweep)."""
    scan = RawScan(swept_ranges(0.0), float(LASER.angles[0]),
                   float(LASER.angles[1] - LASER.angles[0]), time_increment=TIME_INCREMENT)
    landmarks = extract_landmarks(scan, ExtractorSettings()).landmarks
    assert len(landmarks) == 5
    assert np.all(landmarks.beam_time > 0.0) and landmarks.beam_time.max() < 0.15
    assert pole_errors(landmarks.x, landmarks.y, truth(0.0)).max() > 0.3
    back = landmarks.at_first_beam(TURN, (SPEED, 0.0))
    assert pole_errors(back.x, back.y, truth(0.0)).max() < 0.02
    assert np.array_equal(back.radius, landmarks.radius)


def scan_message(t: float, ranges: np.ndarray, time_increment: float) -> LaserScan:
    return LaserScan(header=odometry_message(START + t, np.zeros(3)).header,
                     angle_min=float(LASER.angles[0]),
                     angle_increment=float(LASER.angles[1] - LASER.angles[0]),
                     angle_max=float(LASER.angles[-1]), time_increment=time_increment,
                     range_min=0.05, range_max=LASER.max_range,
                     ranges=np.asarray(ranges, np.float32).tolist())


@pytest.mark.parametrize("deskew", [True, False])
def test_node_deskews_the_landmarks_at_the_odometrys_motion(context, deskew):
    """Odometry at 50 Hz, swept scans at 5 Hz: each scan waits for the odometry covering its
    sweep and its landmarks lie within 2 cm of the poles seen from the stamp's pose (first
    order over the sweep), the first scan's too; with deskew_scans false they are published
    as seen, up to 0.6 m off."""
    node = make_node(context, deskew_scans=deskew)
    recorder = Recorder(node)
    try:
        for step in range(21):
            t = step * 0.02
            if node.reads_odometry:               # deskew_scans false: no odom subscription
                deliver(node, odometry_message(START + t, truth(t)), START + t)
            if step % 10 == 0 and step < 20:
                deliver(node, scan_message(t, swept_ranges(t), TIME_INCREMENT), START + t)
        clouds = recorder.messages["/landmarks"]
        assert len(clouds) == 2
        worst = []
        for cloud in clouds:
            t = ros_io.stamp_to_seconds(cloud.header.stamp) - START
            read = ros_io.read_landmark_cloud(cloud)
            assert read.x.size >= 4
            worst.append(pole_errors(read.x, read.y, truth(round(t, 6))).max())
        assert node.stats["scans_not_deskewed"] == 0
        assert max(worst) < 0.02 if deskew else min(worst) > 0.3
    finally:
        node.destroy_node()


def test_a_sweep_longer_than_the_scan_period_is_not_deskewed_counted_and_warned(context):
    """A driver's time_increment in milliseconds, not seconds: 1,000 times the true sweep
    cannot fit in the 0.2 s between scans, so the landmarks are published as seen (deskewed
    at that sweep they would be thrown far off), counted and reported on /diagnostics."""
    node = make_node(context)
    recorder = Recorder(node)
    try:
        for step in range(21):
            t = step * 0.02
            deliver(node, odometry_message(START + t, truth(t)), START + t)
            if step % 10 == 0 and step < 20:
                deliver(node, scan_message(t, swept_ranges(t), 1000.0 * TIME_INCREMENT),
                        START + t)
        clouds = recorder.messages["/landmarks"]
        assert len(clouds) == 2 and node.stats["scans_not_deskewed"] == 1
        read = ros_io.read_landmark_cloud(clouds[1])
        assert 0.3 < pole_errors(read.x, read.y, truth(0.2)).max() < 0.7     # as seen
        node.flush()
        status = recorder.last_status()
        assert status.level == DiagnosticStatus.WARN and "not deskewed" in status.message
    finally:
        node.destroy_node()


def test_without_odometry_swept_scans_are_published_as_seen_and_diagnostics_say_so(context):
    node = make_node(context)
    recorder = Recorder(node)
    try:
        deliver(node, scan_message(0.0, swept_ranges(0.0), 0.0), START)
        node.flush()
        assert recorder.last_status().level == DiagnosticStatus.OK
        deliver(node, scan_message(0.2, swept_ranges(0.2), TIME_INCREMENT), START + 0.2)
        assert len(recorder.messages["/landmarks"]) == 2      # not held back
        assert node.stats["scans_not_deskewed"] == 1
        node.flush()
        status = recorder.last_status()
        assert status.level == DiagnosticStatus.WARN and "not deskewed" in status.message
    finally:
        node.destroy_node()


def test_a_scan_with_a_time_increment_that_is_not_finite_is_malformed():
    for value in (math.nan, math.inf):
        with pytest.raises(MalformedScanError, match="time_increment"):
            read_scan(scan_message(0.0, np.ones(LASER.beams), value))
    assert read_scan(scan_message(0.0, np.ones(LASER.beams), 1e-4)).time_increment == \
        pytest.approx(1e-4)


@pytest.mark.parametrize("known_motion", [True, False])
def test_the_static_filter_finds_a_pole_of_a_swept_scan_where_the_laser_was(known_motion):
    """Poles seen 0.5 s apart while driving at 3 m/s and turning: the filter looks for each
    in the earlier scan's beams as the laser had moved by the time it took them, and keeps
    every pole; taking that swept scan as taken at once, from its first beam's pose, it finds
    beams that passed beside a pole crossing its place and drops poles as moved."""
    settings = ExtractorSettings()
    kept = []
    motion = (TURN, (SPEED, 0.0)) if known_motion else STILL
    static = StaticFilter(0.5, settings.static_tolerance)     # exact odometry: no heading slack
    for t in (0.0, 0.25, 0.5):
        scan = RawScan(swept_ranges(t), float(LASER.angles[0]),
                       float(LASER.angles[1] - LASER.angles[0]), time_increment=TIME_INCREMENT)
        landmarks = extract_landmarks(scan, settings).landmarks.at_first_beam(TURN, (SPEED, 0.0))
        assert pole_errors(landmarks.x, landmarks.y, truth(t)).max() < 0.02
        kept.append(static.update(t, truth(t), landmarks.x, landmarks.y, scan, motion))
    assert kept[0].all() and len(kept[2]) >= 4
    assert kept[2].all() if known_motion else not kept[2].all()


def test_at_beam_time_undoes_at_first_beam():
    """The pair ``at_first_beam`` / ``at_beam_time``: one the inverse of the other."""
    rng = np.random.default_rng(5)
    x, y, elapsed = rng.uniform(-10, 10, 40), rng.uniform(-10, 10, 40), rng.uniform(0, 0.2, 40)
    back = at_beam_time(*at_first_beam(x, y, elapsed, 0.7, (2.0, -0.3)), elapsed, 0.7,
                        (2.0, -0.3))
    np.testing.assert_allclose(back, (x, y), atol=1e-12)
