# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A laser that sweeps (``core.sweep``): its motion from odometry against finite differences,
and points brought back to the first beam's pose against an exactly integrated unicycle."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fastslam_ros.core.geometry import compose, relative_pose
from fastslam_ros.core.sweep import (STILL, SWEEP_SLACK, SweepMotion, at_first_beam, sweep_end,
                                     sweep_motion, sweep_problem)
from fastslam_ros.tools.simulation.people_sim import sweep_poses


def test_sweep_motion_is_the_lasers_own_velocity_by_finite_differences():
    """The laser's velocity from two odometry poses: turning in place at 0.5 rad/s, a laser
    0.2 m ahead moves sideways at 0.1 m/s; driving straight at 0.4 m/s, a laser facing left
    sees the world go by at -0.4 m/s along its y. Any motion: the laser's own displacement
    over a short step, seen from its frame (finite differences of the composed poses)."""
    rate, velocity = sweep_motion(np.array([1.0, 2.0, 0.3]), np.array([1.0, 2.0, 0.35]), 0.1,
                                  np.array([0.2, 0.0, 0.0]))
    assert rate == pytest.approx(0.5)
    np.testing.assert_allclose(velocity, [0.0, 0.1], atol=1e-12)
    rate, velocity = sweep_motion(np.zeros(3), np.array([0.04, 0.0, 0.0]), 0.1,
                                  np.array([0.0, 0.0, math.pi / 2]))
    assert rate == 0.0
    np.testing.assert_allclose(velocity, [0.0, -0.4], atol=1e-12)
    start, offset, dt = np.array([3.0, -1.0, 2.0]), np.array([0.3, -0.1, 0.4]), 1e-5
    end = start + dt * np.array([0.7 * math.cos(2.0), 0.7 * math.sin(2.0), -0.9])
    laser_start, laser_end = compose(start[None], offset[None])[0], \
        compose(end[None], offset[None])[0]
    expected = relative_pose(laser_start, laser_end)[:2] / dt
    rate, velocity = sweep_motion(start, end, dt, offset)
    assert rate == pytest.approx(-0.9)
    np.testing.assert_allclose(velocity, expected, atol=1e-4)


@pytest.mark.parametrize("speed, turn, elapsed", [(3.0, 0.5, 0.2), (1.0, -2.0, 0.5),
                                                  (0.5, 1e-12, 0.1)])
def test_sweep_motion_of_an_arc_is_its_constant_velocity_not_its_chord(speed, turn, elapsed):
    """A unicycle's arc (``sweep_poses``: exact) at any turn: the laser ahead of the centre
    and turned on it moves at the unicycle's speed plus the turn about the centre, whatever
    the arc's angle (the chord would be off by half of it)."""
    start = np.array([2.0, -1.0, 0.7])
    end = sweep_poses(start, speed, turn, 2, elapsed)[1]
    offset = np.array([0.3, 0.1, 0.5])
    rate, velocity = sweep_motion(start, end, elapsed, offset)
    robot = np.array([speed - turn * offset[1], turn * offset[0]])
    c, s = math.cos(offset[2]), math.sin(offset[2])
    assert rate == pytest.approx(turn, rel=1e-9, abs=1e-15)
    np.testing.assert_allclose(velocity, [c * robot[0] + s * robot[1],
                                          -s * robot[0] + c * robot[1]], atol=1e-9)


@pytest.mark.parametrize("speed, turn", [(0.0, 0.8), (1.5, 0.0), (1.0, -0.6)])
def test_points_seen_during_a_sweep_come_back_to_the_first_beams_pose(speed, turn):
    """Fixed points seen by a laser on a unicycle (exact arcs, ``sweep_poses``) over a 0.1 s
    sweep, each at a later time of the sweep: brought back by ``at_first_beam`` they are where
    the laser at its first beam sees them; exact when the laser only turns or only drives,
    within the first-order error (speed x turn x t^2 / 2) otherwise, while the sweep moved
    them by up to 0.15 m."""
    rng = np.random.default_rng(3)
    points = rng.uniform(-8.0, 8.0, (50, 2))
    start = np.array([1.0, -2.0, 0.4])
    times = np.linspace(0.0, 0.1, 50)
    poses = sweep_poses(start, speed, turn, len(times), times[1])
    local = np.array([relative_pose(pose, np.append(point, 0.0))[:2]
                      for pose, point in zip(poses, points)])
    truth = np.array([relative_pose(start, np.append(point, 0.0))[:2] for point in points])
    x, y = at_first_beam(local[:, 0], local[:, 1], times, turn, (speed, 0.0))
    error = np.hypot(x - truth[:, 0], y - truth[:, 1])
    assert error.max() <= 0.5 * speed * abs(turn) * times[-1] ** 2 + 1e-9
    assert np.hypot(*(local - truth).T).max() > 0.05


def test_a_sweep_fits_its_scan_period_and_the_motion_window():
    """A 270-degree laser at 10 Hz sweeps 1,081 beams in 0.075 s: it fits 0.1 s between scans
    (and 0.2 s after a lost scan); the same time_increment in milliseconds does not, nor does
    a scan more than the window after the previous one, whose motion is too old."""
    increment = 0.075 / 1080
    assert sweep_problem(increment, 1081, 0.1, 0.5) == ""
    assert sweep_problem(-increment, 1081, 0.2, 0.5) == ""
    assert "longer than the 0.1 s" in sweep_problem(1000.0 * increment, 1081, 0.1, 0.5)
    assert sweep_problem(0.1 * SWEEP_SLACK / 1080 * 0.999, 1081, 0.1, 0.5) == ""
    assert sweep_problem(0.1 * SWEEP_SLACK / 1080 * 1.001, 1081, 0.1, 0.5) != ""
    assert "over 0.5 s" in sweep_problem(increment, 1081, 0.6, 0.5)
    assert sweep_problem(increment, 1081, 0.0, 0.5) != ""


def test_a_sweep_the_odometry_covers_is_deskewed_at_its_own_motion_not_the_previous_scans():
    """A robot turning at 0.4 rad/s up to a scan's stamp and at 0.8 rad/s over its 0.1 s
    sweep: with the odometry pose at the sweep's last beam the motion is the sweep's 0.8 rad/s
    (also for the first scan, which has none before it); without it, the 0.4 rad/s since the
    previous scan. A sweep longer than the scan period is still not deskewed."""
    offset = np.zeros(3)
    beams, increment = 541, 0.1 / 540
    motions = SweepMotion()
    first, problem = motions.motion(0.0, np.zeros(3), increment, beams, offset,
                                    np.array([0.0, 0.0, 0.08]))
    assert problem == "" and first[0] == pytest.approx(0.8)
    at_stamp = np.array([0.0, 0.0, 0.04])       # 0.1 s at 0.4 rad/s since the previous scan
    covered, problem = motions.motion(0.1, at_stamp, increment, beams, offset,
                                      at_stamp + [0.0, 0.0, 0.08])
    assert problem == "" and covered[0] == pytest.approx(0.8)
    motions.clear()
    motions.motion(0.0, np.zeros(3), increment, beams, offset)
    uncovered, problem = motions.motion(0.1, at_stamp, increment, beams, offset)
    assert problem == "" and uncovered[0] == pytest.approx(0.4)
    assert sweep_end(0.1, increment, beams) == pytest.approx(0.2)
    long_sweep = 1000.0 * increment                  # a time_increment in milliseconds
    assert sweep_end(0.1, long_sweep, beams) == 0.1  # waits for no odometry
    motions.motion(0.2, at_stamp, long_sweep, beams, offset)
    still, problem = motions.motion(0.3, at_stamp, long_sweep, beams, offset, at_stamp)
    assert still == STILL and "longer than" in problem
