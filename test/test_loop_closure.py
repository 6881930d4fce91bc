# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Loop closure confirmed across readings (``loop_closure_matches``, core/loop_closure.py)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fastslam_ros.core import FastSLAM, FastSLAMConfig
from model_helpers import drifting_loop

LOOP_CONFIG = FastSLAMConfig(num_particles=30, sigma_range=0.05, sigma_bearing=0.01,
                             max_range=8.0, alpha1=1e-4, alpha2=1e-5, alpha3=1e-4, alpha4=1e-5,
                             cell_size=5.0)


def run_drifting_loop(matches: int, backend: str = "numpy", seed: int = 1,
                      association: str = "ml"):
    """The filter over ``drifting_loop(seed)``: (filter, true final pose, duplicated ids of
    the best map, the per-step (poses, log weights))."""
    truth, odometry, landmarks, sensor, rng = drifting_loop(seed, heading_bias=1e-3)
    slam = FastSLAM(LOOP_CONFIG.replace(loop_closure_matches=matches, backend=backend,
                                        association=association),
                    rng=np.random.default_rng(5), initial_pose=truth[0])
    steps = []
    for t in range(1, len(truth)):
        slam.predict(odometry[t - 1], odometry[t])
        reading = sensor.observe(truth[t], landmarks, rng)
        slam.update(reading.ranges, reading.bearings, reading.labels, stamp=float(t))
        steps.append((slam.poses.copy(), slam.log_weights.copy()))
    ids, counts = np.unique(slam.best_map().ids, return_counts=True)
    return slam, truth[-1], ids[counts > 1], steps


def test_a_drifted_loop_closes_on_old_landmarks_instead_of_mapping_them_twice():
    """Odometry 4.6 m off after 1.2 laps: without the step the filter maps five landmarks of
    the start a second time and ends 0.7 m from the truth; two agreeing old landmarks shift
    it back onto its old map."""
    plain, truth, plain_duplicates, _ = run_drifting_loop(0)
    assert len(plain_duplicates) >= 4
    assert math.dist(plain.best_pose()[:2], truth[:2]) > 0.5
    slam, truth, duplicates, _ = run_drifting_loop(2)
    assert slam.loop.num_closures > 0
    assert math.dist(slam.best_pose()[:2], truth[:2]) < 0.3
    assert len(duplicates) < len(plain_duplicates)


def drive_away_and_back(matches: int) -> FastSLAM:
    """A loaded map of one landmark at (-5, 0), 40 m of odometry without detections (out
    20 m along +x, turn round, back), then a landmark detected 1 m beyond it: outside the
    association gate, inside the drift-widened one."""
    config = LOOP_CONFIG.replace(loop_closure_matches=matches, min_translation_sigma=1e-4,
                                 min_rotation_sigma=1e-5, alpha1=0.0, alpha2=0.0, alpha3=0.0,
                                 alpha4=0.0, logodds_missed=0.0)
    slam = FastSLAM(config, rng=np.random.default_rng(2))
    slam.seed_map([[-5.0, 0.0]], [np.eye(2) * 0.01])
    odometry = [(0.5 * k, 0.0, 0.0) for k in range(41)]
    odometry += [(20.0, 0.0, math.pi * k / 8) for k in range(1, 9)]
    odometry += [(20.0 - 0.5 * k, 0.0, math.pi) for k in range(1, 41)]
    for k in range(1, len(odometry)):
        slam.predict(odometry[k - 1], odometry[k])
        slam.update([], [], stamp=float(k))
    for k in range(3):  # three detections confirm the new landmark (existence 0.95)
        slam.update([6.0], [0.0], stamp=float(len(odometry) + k))
    return slam


def test_a_single_wide_match_does_not_shift_the_pose():
    """One old landmark disagreeing with a detection leaves the filter as it is without the
    step (the same draws: the same poses and map); only k = 1 would move it by the 1 m."""
    plain, guarded, eager = (drive_away_and_back(k) for k in (0, 2, 1))
    np.testing.assert_array_equal(guarded.poses, plain.poses)
    np.testing.assert_array_equal(guarded.best_map().means, plain.best_map().means)
    assert len(plain.best_map()) == 2
    assert guarded.loop.num_closures == 0 and (guarded.loop.support == 1).all()
    assert eager.loop.num_closures == eager.num_particles
    np.testing.assert_allclose(eager.poses[:, :2] - plain.poses[:, :2],
                               np.broadcast_to([1.0, 0.0], plain.poses[:, :2].shape),
                               atol=0.05)
    assert len(eager.best_map()) == 1


OLD = np.array([[-5.0, 1.5], [-5.0, -1.5], [-6.5, 0.0]])
"""A loaded map of three landmarks behind the start."""
FAR = np.array([20.0, 4.0])
"""A landmark mapped on the way out, 20 m from where the loop closes."""


def drive_round_and_detect(matches: int, true_pose: np.ndarray) -> FastSLAM:
    """The loaded map ``OLD``, odometry out 20 m along +x (``FAR`` detected from x >= 14 m),
    a turn and back to the start; then the three old landmarks detected from ``true_pose``,
    where the robot really is: the odometry's end is off by a known drift, beyond the
    association gate."""
    config = LOOP_CONFIG.replace(loop_closure_matches=matches, min_translation_sigma=1e-4,
                                 min_rotation_sigma=1e-5, alpha1=0.0, alpha2=0.0, alpha3=0.0,
                                 alpha4=0.0, logodds_missed=0.0)
    slam = FastSLAM(config, rng=np.random.default_rng(2))
    slam.seed_map(OLD, [np.eye(2) * 0.01] * len(OLD))
    odometry = [(0.5 * k, 0.0, 0.0) for k in range(41)]
    odometry += [(20.0, 0.0, math.pi * k / 8) for k in range(1, 9)]
    odometry += [(20.0 - 0.5 * k, 0.0, math.pi) for k in range(1, 41)]
    for k in range(1, len(odometry)):
        slam.predict(odometry[k - 1], odometry[k])
        x, _, heading = odometry[k]
        d = FAR - odometry[k][:2]
        if 14.0 <= x and heading == 0.0:
            slam.update([math.hypot(*d)], [math.atan2(d[1], d[0])], stamp=float(k))
        else:
            slam.update([], [], stamp=float(k))
    d = OLD - true_pose[:2]
    bearings = (np.arctan2(d[:, 1], d[:, 0]) - true_pose[2] + math.pi) % (2 * math.pi) - math.pi
    for k in range(4):  # detections confirm the new landmarks (existence 0.95 after three)
        slam.update(np.hypot(d[:, 0], d[:, 1]), bearings, stamp=float(len(odometry) + k))
    return slam


@pytest.mark.parametrize("true_pose", [(1.0, 0.0, math.pi), (0.8, 0.4, math.pi),
                                       (0.6, -0.5, math.pi + 0.02)])
def test_a_known_drift_closes_onto_the_true_pose_and_keeps_the_far_map(true_pose):
    """The closure moves the pose onto where the robot is (a drift of about 1 m) and onto the
    old landmarks instead of mapping them again; the landmark mapped far away keeps the place
    it has without the step (bending the correction over the map by the distance travelled
    moved it 0.2-0.4 m)."""
    true_pose = np.array(true_pose)
    plain, slam = drive_round_and_detect(0, true_pose), drive_round_and_detect(2, true_pose)
    assert slam.loop.num_closures > 0
    pose = slam.best_pose()
    assert math.dist(pose[:2], true_pose[:2]) < 0.1
    assert abs((pose[2] - true_pose[2] + math.pi) % (2 * math.pi) - math.pi) < 0.02
    assert len(plain.best_map()) == len(OLD) + 1 + len(OLD)
    means = slam.best_map().means
    assert len(means) < len(plain.best_map())
    far = means[np.argmin(np.linalg.norm(means - FAR, axis=1))]
    plain_means = plain.best_map().means
    np.testing.assert_allclose(far, plain_means[np.argmin(np.linalg.norm(plain_means - FAR,
                                                                         axis=1))], atol=0.01)
    for old in OLD:
        assert np.linalg.norm(means - old, axis=1).min() < 0.05


def test_closures_in_clutter_move_the_pose_towards_the_truth(monkeypatch):
    """The drifting loop with a false detection per reading and one landmark in ten missed
    (seeds 1-5): loops close, and each closure brings the closing particles nearer to the
    true pose (a closure on clutter or on a wrong pair would move them away)."""
    from fastslam_ros.core import loop_closure

    truth_now, moves = [None], []
    close = loop_closure.LoopClosure._close

    def spy(self, cache, poses, rows):
        moved = close(self, cache, poses, rows)
        before, after = (np.linalg.norm(p[rows, :2] - truth_now[0][:2], axis=1).mean()
                         for p in (poses, moved))
        moves.append((before, after))
        return moved

    monkeypatch.setattr(loop_closure.LoopClosure, "_close", spy)
    for seed in range(1, 6):
        truth, odometry, landmarks, sensor, rng = drifting_loop(seed, heading_bias=1e-3)
        sensor = dataclasses.replace(sensor, clutter_rate=1.0, detection_probability=0.9)
        slam = FastSLAM(LOOP_CONFIG.replace(loop_closure_matches=2),
                        rng=np.random.default_rng(5), initial_pose=truth[0])
        for t in range(1, len(truth)):
            slam.predict(odometry[t - 1], odometry[t])
            truth_now[0] = truth[t]
            reading = sensor.observe(truth[t], landmarks, rng)
            slam.update(reading.ranges, reading.bearings, reading.labels, stamp=float(t))
    assert len(moves) >= 3
    for before, after in moves:
        assert after < 0.5 * before


def test_readings_that_see_nothing_before_the_first_landmark():
    """Empty readings at the start (a detector that holds its first scans back) leave the
    filter with no landmark to look up; they used to raise an IndexError."""
    slam = FastSLAM(FastSLAMConfig(loop_closure_matches=2, num_particles=10, seed=1))
    for _ in range(3):
        slam.update(np.zeros(0), np.zeros(0))
    slam.update(np.array([5.0]), np.array([0.3]))
    assert len(slam.particle_map(slam.best_index())[0]) == 1
