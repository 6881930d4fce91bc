# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The saved map's batch least squares (core/map_refinement.py), against known truth."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fastslam_ros.core import FastSLAM, FastSLAMConfig, LandmarkMap
from fastslam_ros.core import map_refinement as mr
from fastslam_ros.core.geometry import compose, relative_pose, wrap_angle
from fastslam_ros.core.observation import SensorOffset, inverse_observe
from fastslam_ros.tools.simulation.world import RangeBearingSensor
from model_helpers import drifting_loop, observe

LOOP_CONFIG = FastSLAMConfig(num_particles=30, sigma_range=0.05, sigma_bearing=0.01,
                             max_range=8.0, alpha1=1e-4, alpha2=1e-5, alpha3=1e-4, alpha4=1e-5,
                             cell_size=5.0, loop_closure_matches=2, backend="numpy")


def map_error(landmark_map: LandmarkMap, truth: np.ndarray) -> float:
    """RMS distance (m) of the map's labelled landmarks from their true positions."""
    labelled = landmark_map.ids >= 0
    offsets = landmark_map.means[labelled] - truth[landmark_map.ids[labelled]]
    return float(np.sqrt((offsets ** 2).sum(axis=1).mean()))


def test_the_refined_map_of_a_closed_loop_is_closer_to_the_truth():
    """A loop whose odometry turns 1 mrad too far each step, closed by ``loop_closure_matches``:
    the closure moves the pose and the landmarks near it, the far side keeps its drift. The
    least squares over the best particle's path puts the map nearer the truth."""
    truth, odometry, landmarks, sensor, rng = drifting_loop(1, heading_bias=1e-3)
    slam = FastSLAM(LOOP_CONFIG, rng=np.random.default_rng(5), initial_pose=truth[0])
    for t in range(1, len(truth)):
        slam.predict(odometry[t - 1], odometry[t])
        reading = sensor.observe(truth[t], landmarks, rng)
        slam.update(reading.ranges, reading.bearings, reading.labels, stamp=float(t))
    assert slam.loop.num_closures > 0
    filtered = slam.best_map(LOOP_CONFIG.map_min_existence)
    refined, report = mr.refine_best_map(slam)
    assert report.readings == len(truth) - 1 and report.refined == len(filtered)
    assert report.associated > 0.8 * report.observations
    assert report.final_cost < report.initial_cost
    np.testing.assert_array_equal(refined.keys, filtered.keys)
    assert map_error(refined, landmarks) < 0.6 * map_error(filtered, landmarks)
    assert np.all(np.linalg.eigvalsh(refined.covariances) > 0.0)


def test_jacobian_matches_finite_differences():
    rng = np.random.default_rng(3)
    count, size, observations = 6, 4, 15
    poses = np.column_stack([rng.normal(0.0, 3.0, (count, 2)), rng.uniform(-3.0, 3.0, count)])
    landmarks = rng.normal(0.0, 6.0, (size, 2))
    config = FastSLAMConfig(sensor_x=0.3, sensor_y=-0.2, sensor_yaw=0.1)
    increments = rng.normal(0.0, 1.0, (count - 1, 3))
    problem = mr.Problem(increments, mr.odometry_whitening(increments, config),
                         poses[0] + 0.01, rng.integers(0, count, observations),
                         rng.integers(0, size, observations), rng.uniform(2.0, 8.0, observations),
                         rng.uniform(-3.0, 3.0, observations), np.full(observations, 0.1), 0.02,
                         SensorOffset(0.3, -0.2, 0.1))
    weights = rng.uniform(0.2, 1.0, observations)

    def stacked(x):
        prior, odometry, observed = mr.residuals(problem, x[:3 * count].reshape(-1, 3),
                                                 x[3 * count:].reshape(-1, 2))
        return np.concatenate([prior, odometry.ravel(),
                               (observed * np.sqrt(weights)[:, None]).ravel()])

    x = np.concatenate([poses.ravel(), landmarks.ravel()])
    analytic = mr.jacobian(problem, poses, landmarks, weights).toarray()
    numeric = np.empty_like(analytic)
    for i in range(len(x)):
        step = np.zeros_like(x)
        step[i] = 1e-6
        numeric[:, i] = (stacked(x + step) - stacked(x - step)) / 2e-6
    np.testing.assert_allclose(analytic, numeric, atol=1e-5 * np.abs(numeric).max())


def corridor(seed: int = 2, steps: int = 80):
    """A straight drive along x through two rows of landmarks: truth poses (T, 3), landmarks
    (N, 2), the readings (ranges, bearings, ids) seen from the truth with small noise."""
    rng = np.random.default_rng(seed)
    truth = np.column_stack([np.linspace(0.0, 40.0, steps), np.zeros(steps), np.zeros(steps)])
    xs = np.arange(0.0, 42.0, 3.0)
    landmarks = np.concatenate([np.column_stack([xs, np.full_like(xs, 4.0)]),
                                np.column_stack([xs + 1.5, np.full_like(xs, -4.0)])])
    landmarks += rng.normal(0.0, 0.3, landmarks.shape)
    sensor = RangeBearingSensor(8.0, 0.02, 0.005)
    readings = [sensor.observe(pose, landmarks, rng) for pose in truth]
    return truth, landmarks, readings


def logged(truth, readings, labels=None) -> mr.ReadingLog:
    """A log of exact odometry along ``truth`` with these readings."""
    log = mr.ReadingLog()
    for t, (pose, reading) in enumerate(zip(truth, readings)):
        if t:
            log.move(relative_pose(truth[t - 1], pose))
        ids = reading.labels if labels is None else labels[t]
        log.record(float(t), reading.ranges, reading.bearings, np.asarray(ids, np.int64))
    return log


def bent_estimate(truth, landmarks, readings, bend: float):
    """A path whose heading bends by ``bend`` rad per step and the map it sees: each landmark
    the mean of its observations' inverse model from that path (consistent with it, far
    from the truth)."""
    steps = relative_pose(truth[:-1], truth[1:])
    path = [truth[0]]
    for step in steps:
        path.append(compose(path[-1], step + np.array([0.0, 0.0, bend])))
    path = np.array(path)
    sums = np.zeros_like(landmarks)
    counts = np.zeros(len(landmarks))
    for pose, reading in zip(path, readings):
        points = inverse_observe(np.broadcast_to(pose, (len(reading.ranges), 3)),
                                 reading.ranges, reading.bearings)
        np.add.at(sums, reading.labels, points)
        np.add.at(counts, reading.labels, 1.0)
    seen = counts > 0
    means = sums[seen] / counts[seen][:, None]
    size = int(seen.sum())
    bent_map = LandmarkMap(means, np.tile(np.eye(2) * 0.01, (size, 1, 1)), np.ones(size),
                           np.flatnonzero(seen), np.arange(size))
    return path, bent_map


def test_a_bent_map_with_right_associations_is_straightened():
    truth, landmarks, readings = corridor()
    path, bent = bent_estimate(truth, landmarks, readings, bend=0.004)
    config = FastSLAMConfig(sigma_range=0.02, sigma_bearing=0.005, alpha1=1e-4, alpha2=1e-5,
                            alpha3=1e-4, alpha4=1e-5)
    assert map_error(bent, landmarks) > 1.0
    refined, report = mr.refine(logged(truth, readings), np.arange(len(truth), dtype=float),
                                path, bent, config, known_ids=True)
    assert report.associated == report.observations
    assert map_error(refined, landmarks) < 0.05
    # The nearest-landmark association finds the same landmarks from the bent path.
    nearest, _ = mr.refine(logged(truth, readings), np.arange(len(truth), dtype=float), path,
                           bent, config)
    assert map_error(nearest, landmarks) < 0.05


def test_a_wrong_association_is_down_weighted():
    """One observation of a landmark labelled as another 8 m away: the Cauchy loss leaves it a
    small weight and the map where the right associations put it."""
    truth, landmarks, readings = corridor(seed=4)
    labels = [reading.labels.copy() for reading in readings]
    wrong_reading = 40
    labels[wrong_reading][0] = (labels[wrong_reading][0] + 5) % len(landmarks)
    config = FastSLAMConfig(sigma_range=0.02, sigma_bearing=0.005, alpha1=1e-4, alpha2=1e-5,
                            alpha3=1e-4, alpha4=1e-5)
    ids = np.arange(len(landmarks))
    exact = LandmarkMap(landmarks.copy(), np.tile(np.eye(2) * 0.01, (len(ids), 1, 1)),
                        np.ones(len(ids)), ids, ids)
    stamps = np.arange(len(truth), dtype=float)
    right, _ = mr.refine(logged(truth, readings), stamps, truth, exact, config, known_ids=True)
    wrong, _ = mr.refine(logged(truth, readings, labels), stamps, truth, exact, config,
                         known_ids=True)
    assert np.abs(wrong.means - right.means).max() < 0.05
    # The solve's own weights: the wrong observation's is small, the others' near one.
    _, odometry, reading, ranges, bearings, observed_ids = logged(truth, readings,
                                                                 labels).readings()
    increments = relative_pose(odometry[:-1], odometry[1:])
    problem = mr.Problem(increments, mr.odometry_whitening(increments, config), truth[0],
                         reading, observed_ids, ranges, bearings,
                         np.full(len(ranges), config.sigma_range), config.sigma_bearing,
                         SensorOffset())
    _, _, weights, _, _, _ = mr.solve(problem, truth.copy(), landmarks.copy())
    first_of_wrong = np.flatnonzero(reading == wrong_reading)[0]
    assert weights[first_of_wrong] < 0.05
    assert np.median(np.delete(weights, first_of_wrong)) > 0.7  # 2 dof: E|e|^2 = 2


def test_the_log_stays_within_its_caps_and_keeps_the_odometry_exact():
    rng = np.random.default_rng(0)
    log = mr.ReadingLog(max_readings=16, max_observations=40)
    pose = np.zeros(3)
    poses = []
    for t in range(100):
        step = np.array([0.5, 0.0, rng.uniform(-0.1, 0.1)])
        log.move(step)
        pose = compose(pose, step)
        poses.append(pose)
        count = int(rng.integers(0, 4))
        log.record(float(t), np.full(count, float(t) + 1.0), np.zeros(count),
                   np.full(count, t, np.int64))
        assert len(log) <= 16
    stamps, odometry, reading, ranges, _, labels = log.readings()
    assert log.thinned and stamps[-1] == 99.0 and len(ranges) <= 40
    assert np.all(np.diff(stamps) > 0)
    np.testing.assert_allclose(odometry, np.array(poses)[stamps.astype(int)], atol=1e-9)
    # Each observation is still filed under its own reading.
    np.testing.assert_array_equal(labels, stamps[reading].astype(int))
    np.testing.assert_array_equal(ranges, stamps[reading] + 1.0)


def test_a_path_thinned_more_than_the_log_is_filled_by_odometry():
    truth, landmarks, readings = corridor()
    log = logged(truth, readings)
    stamps = np.arange(len(truth), dtype=float)
    kept = np.concatenate([np.arange(0, 40, 2), np.arange(40, len(truth))])
    odometry = log.readings()[1]
    poses = mr.initial_poses(stamps, odometry, stamps[kept], truth[kept])
    np.testing.assert_allclose(poses[:, :2], truth[:, :2], atol=1e-9)
    np.testing.assert_allclose(wrap_angle(poses[:, 2] - truth[:, 2]), 0.0, atol=1e-9)


def test_nothing_to_refine_is_an_error():
    with pytest.raises(ValueError, match="nothing to refine"):
        mr.refine(mr.ReadingLog(), np.zeros(0), np.zeros((0, 3)),
                  LandmarkMap(np.zeros((0, 2)), np.zeros((0, 2, 2)), np.zeros(0),
                              np.zeros(0, np.int64), np.zeros(0, np.int64)), FastSLAMConfig())


def test_observe_and_the_residuals_agree():
    """The least squares' observation residual is zero at the model's own prediction."""
    pose, landmark = np.array([1.0, 2.0, 0.3]), np.array([[5.0, 4.0]])
    offset = SensorOffset(0.2, 0.1, -0.2)
    z = observe(pose, landmark[0], offset)
    problem = mr.Problem(np.zeros((1, 3)), np.tile(np.eye(3), (1, 1, 1)), pose,
                         np.array([0]), np.array([0]), z[:1], z[1:], np.array([0.1]), 0.01,
                         offset)
    _, _, observed = mr.residuals(problem, np.array([pose, pose]), landmark)
    np.testing.assert_allclose(observed, 0.0, atol=1e-12)


def test_a_long_log_is_solved_on_keyframes():
    """Beyond ``max_solve_poses`` readings every k-th pose is solved for and the others follow
    it by odometry: with exact odometry the bent map is straightened as well (with a lever
    arm, which the keyframes' per-observation sensor poses carry)."""
    truth, landmarks, readings = corridor()
    offset = SensorOffset(0.5, -0.3, 0.2)
    shifted = []
    for pose, reading in zip(truth, readings):  # the same points, seen from the lever arm
        sensor = compose(pose, np.array([offset.x, offset.y, offset.yaw]))
        z = observe(np.broadcast_to(sensor, (len(reading.labels), 3)), landmarks[reading.labels])
        shifted.append(dataclasses.replace(reading, ranges=z[:, 0], bearings=z[:, 1]))
    config = FastSLAMConfig(sigma_range=0.02, sigma_bearing=0.005, alpha1=1e-4, alpha2=1e-5,
                            alpha3=1e-4, alpha4=1e-5, sensor_x=offset.x, sensor_y=offset.y,
                            sensor_yaw=offset.yaw)
    path, _ = bent_estimate(truth, landmarks, readings, bend=0.004)
    ids = np.arange(len(landmarks))
    bent = LandmarkMap(landmarks + np.array([0.0, 1.0]),
                       np.tile(np.eye(2) * 0.01, (len(ids), 1, 1)), np.ones(len(ids)), ids, ids)
    refined, report = mr.refine(logged(truth, shifted), np.arange(len(truth), dtype=float), path,
                                bent, config, known_ids=True, max_solve_poses=20)
    assert len(report.poses) == 20
    np.testing.assert_allclose(report.poses[:, :2], truth[::4, :2], atol=0.01)
    assert map_error(refined, landmarks) < 0.01
