# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Recovery from odometry faults (``fault_recovery_matches``, core/fault_recovery.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fastslam_ros.core import FastSLAM, FastSLAMConfig
from fastslam_ros.core.fault_recovery import FaultRecovery
from fastslam_ros.core.landmark_clock import LandmarkClock
from fastslam_ros.core.params import ParameterValueError
from fastslam_ros.tools.simulation.sim import SimConfig, simulate
from test_turn_faults import faults_run

GATE = 0.3


def rotated_copies(rotation: float, seen_late: int = 0, spacing: float = 0.0):
    """A map of 12 old landmarks (keys 0-11, created and last observed at 0 m) and young
    copies (keys 12-15, created at 20 m) of landmarks 0-3 rotated by ``rotation`` about the
    robot at (1, 2) heading 0.3 and pushed ``spacing`` metres along x; the first
    ``seen_late`` of landmarks 0-3 were observed again at 25 m. Returns (recovery, robot pose,
    landmarks as ``FastSLAM.particle_map`` gives them)."""
    rng = np.random.default_rng(7)
    old = rng.uniform(-6.0, 8.0, (12, 2))
    robot = np.array([1.0, 2.0, 0.3])
    c, s = math.cos(rotation), math.sin(rotation)
    offset = old[:4] - robot[:2]
    young = offset @ np.array([[c, s], [-s, c]]) + robot[:2] + [spacing, 0.0]
    means = np.vstack([old, young])
    count = len(means)
    clock = LandmarkClock()
    clock.register(12)
    clock.travelled = 20.0
    clock.register(count)
    clock.travelled = 30.0
    clock.seen[:seen_late] = 25.0
    recovery = FaultRecovery(3, GATE, 0.9, 5.0, clock)
    landmarks = (means, np.tile([0.01, 0.0, 0.01], (count, 1)), np.full(count, 5.0),
                 np.full(count, -1), np.arange(count))
    return recovery, robot, landmarks


def test_a_rotated_copy_of_older_landmarks_moves_the_robot_back():
    """Four young landmarks that are the old landmarks 0-3 turned 0.6 rad about the robot:
    the correction turns the robot -0.6 rad about itself and names the four as copies
    (closed form: the inverse of the rotation that made them)."""
    recovery, robot, landmarks = rotated_copies(0.6)
    correction = recovery.search(robot, landmarks, stamp=0.0)
    assert correction is not None
    assert correction.rotation == pytest.approx(-0.6, abs=1e-6)
    np.testing.assert_allclose(correction.shift, 0.0, atol=1e-6)
    assert sorted(correction.copy_keys) == [12, 13, 14, 15]
    np.testing.assert_allclose(correction.apply(landmarks[0][12:]), landmarks[0][:4],
                               atol=1e-6)


def test_no_correction_from_copies_of_landmarks_observed_since_they_were_made():
    """The same copies, but two of their originals were observed after the copies were
    created: the robot saw those where they are, so only two copies remain (fewer than
    k = 3) and nothing moves."""
    recovery, robot, landmarks = rotated_copies(0.6, seen_late=2)
    assert recovery.search(robot, landmarks, stamp=0.0) is None


def test_young_landmarks_next_to_old_ones_are_neighbours_not_copies():
    """Young landmarks 0.2 m from old ones (within the gate without any move): no
    correction, whatever the search finds."""
    recovery, robot, landmarks = rotated_copies(0.0, spacing=0.2)
    assert recovery.search(robot, landmarks, stamp=0.0) is None


def test_new_territory_is_not_a_copy():
    """Young landmarks whose shape matches no part of the old map: no correction."""
    recovery, robot, landmarks = rotated_copies(0.6)
    means = landmarks[0].copy()
    means[12:] = [[20.0, 20.0], [23.1, 21.7], [18.4, 25.3], [26.0, 19.2]]
    assert recovery.search(robot, (means,) + landmarks[1:], stamp=0.0) is None


def test_one_search_per_second_of_data():
    recovery, robot, landmarks = rotated_copies(0.6)
    assert recovery.search(robot, landmarks, stamp=10.0) is not None
    assert recovery.search(robot, landmarks, stamp=10.5) is None
    assert recovery.search(robot, landmarks, stamp=11.0) is not None


def test_the_faults_scenario_stays_on_its_map_with_recovery():
    """The faults scenario (two turns not made a minute), seeds 1-3, configured as a user
    would plus ``fault_recovery_matches: 3``: every seed within 0.2 m (without it, some
    seed exceeds 0.5 m: ``test_turn_faults``)."""
    errors = [faults_run(seed, 0.0, fault_recovery_matches=3) for seed in (1, 2, 3)]
    assert max(errors) < 0.2, errors


def test_fault_recovery_is_checked():
    with pytest.raises(ParameterValueError, match="fault_recovery_matches"):
        FastSLAMConfig(fault_recovery_matches=2).validate()
    with pytest.raises(ParameterValueError, match="fault_recovery_gate"):
        FastSLAMConfig(fault_recovery_gate=0.0).validate()


def test_fault_recovery_is_the_same_on_both_backends():
    """The recovery is a numpy step after either backend's reading: on 60 s of the faults
    scenario both backends make the same corrections and end at the same poses."""
    pytest.importorskip("numba")
    bag = simulate(SimConfig(scenario="faults", duration=60.0))
    runs = []
    for backend in ("numpy", "numba"):
        config = FastSLAMConfig(max_range=5.6, min_range=0.4, field_of_view=4.2,
                                sensor_x=0.219, sigma_range=0.03, sigma_bearing=0.026, seed=1,
                                fault_recovery_matches=3, backend=backend)
        slam = FastSLAM(config, initial_pose=bag.odometry.poses[0])
        index = np.searchsorted(bag.odometry.stamps, bag.scans.stamps - 1e-9)
        previous = bag.odometry.poses[0]
        for stamp, step, points in zip(bag.scans.stamps, index, bag.scans.points):
            slam.predict(previous, bag.odometry.poses[step])
            previous = bag.odometry.poses[step]
            slam.update(np.hypot(points[:, 0], points[:, 1]),
                        np.arctan2(points[:, 1], points[:, 0]), stamp=float(stamp))
        runs.append(slam)
    assert runs[0].fault.num_recoveries == runs[1].fault.num_recoveries > 0
    np.testing.assert_allclose(runs[0].poses, runs[1].poses, atol=1e-9, rtol=0)


def test_a_match_no_turn_explains_is_not_taken():
    """Young landmarks that are old ones shifted 3 m without a turn (new territory that
    happens to repeat the old map's shape): a turn not made moves the robot by at most the
    turn times the recent travel, so no correction."""
    recovery, robot, landmarks = rotated_copies(0.0, spacing=3.0)
    assert recovery.search(robot, landmarks, stamp=0.0) is None
