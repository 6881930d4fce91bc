# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The filter on simulated worlds: accuracy, association, clutter removal, numerics, estimates."""
from __future__ import annotations

import numpy as np
import pytest

from fastslam_ros.core import FastSLAM, FastSLAMConfig
from fastslam_ros.core.geometry import compose
from fastslam_ros.tools.simulation.synthetic import make_world


BACKEND = {"name": "numpy"}
"""The backend ``config`` builds the filters of the running test with."""


@pytest.fixture(autouse=True)
def on_each_backend(backend, monkeypatch):
    """Every behaviour test runs on the numpy reference and on the compiled backend."""
    monkeypatch.setitem(BACKEND, "name", backend)


def config(**changes) -> FastSLAMConfig:
    base = FastSLAMConfig(num_particles=50, sigma_range=0.1, sigma_bearing=0.02,
                          alpha1=0.01, alpha2=0.0005, alpha3=0.01, alpha4=0.001,
                          max_range=12.0, new_landmark_likelihood=1e-3, seed=1,
                          backend=BACKEND["name"])
    return base.replace(**changes)


def aligned_rmse(estimate: np.ndarray, truth: np.ndarray) -> float:
    """Position RMSE after the least-squares rotation + translation (2-D Kabsch)."""
    est_c, tru_c = estimate - estimate.mean(0), truth - truth.mean(0)
    u, _, vt = np.linalg.svd(est_c.T @ tru_c)
    d = np.sign(np.linalg.det(u @ vt))
    rotation = (u @ np.diag([1.0, d]) @ vt).T
    residual = est_c @ rotation.T - tru_c
    return float(np.sqrt(np.mean(np.sum(residual ** 2, axis=1))))


def test_aligned_rmse_removes_a_rigid_motion_exactly():
    rng = np.random.default_rng(0)
    truth = rng.normal(size=(50, 2))
    angle = 0.7
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    assert aligned_rmse(truth @ rotation.T + [3.0, -1.0], truth) < 1e-12
    assert aligned_rmse(truth + rng.normal(0, 0.1, truth.shape), truth) > 0.05


def run(slam, world):
    """Feed the world; return (aligned position RMSE, same for dead reckoning, association)."""
    previous = world.steps[0].odometry
    errors, dead_reckoning, checked, correct, seen = [], [], 0, 0, set()
    for k, step in enumerate(world.steps[1:]):
        slam.predict(previous, step.odometry)
        previous = step.odometry
        report = slam.update(step.ranges, step.bearings, step.ids, stamp=float(k))
        for j, label in enumerate(step.ids):
            if label < 0:
                continue
            checked += 1
            if report.is_new[j]:
                correct += label not in seen
            else:
                correct += report.associated_ids[j] == label
            seen.add(label)
        errors.append(slam.best_pose()[:2])
        dead_reckoning.append(step.odometry[:2])
    truth = np.array([s.truth[:2] for s in world.steps[1:]])
    return (aligned_rmse(np.array(errors), truth), aligned_rmse(np.array(dead_reckoning), truth),
            correct / max(checked, 1))


@pytest.mark.parametrize("algorithm", ["fastslam1", "fastslam2"])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_unknown_association_beats_dead_reckoning_and_associates_right(algorithm, seed):
    world = make_world(seed=seed, num_steps=400, laps=2.0)
    slam = FastSLAM(config(algorithm=algorithm, seed=seed, alpha2=0.0006, alpha3=0.005),
                    initial_pose=world.steps[0].truth)
    error, dead_reckoning, association = run(slam, world)
    assert error < 0.3 * dead_reckoning, (error, dead_reckoning)
    assert association >= 0.99
    seen = set(np.concatenate([s.ids for s in world.steps]).tolist())
    found = slam.best_map()
    assert set(found.ids.tolist()) == seen
    assert len(found) <= len(seen) + 1


def test_clutter_is_eliminated_and_true_landmarks_stay():
    world = make_world(seed=4, num_steps=300, clutter_per_step=0.35, detection_probability=0.95)
    clutter = sum(np.sum(s.ids < 0) for s in world.steps)
    total = world.num_observations
    assert 0.03 < clutter / total < 0.08          # about 5 % of detections are clutter
    # Negative evidence only well inside the sensor's 12 m reach (no edge effects).
    slam = FastSLAM(config(algorithm="fastslam2", logodds_missed=-0.6, logodds_remove=-1.0,
                           max_range=11.0), initial_pose=world.steps[0].truth)
    run(slam, world)
    # Landmarks confirmed at least once after their creation (clutter from the last few
    # readings cannot have been refuted yet).
    found = slam.best_map(min_existence=0.8)
    spurious = np.sum(found.ids < 0)
    assert spurious <= 0.05 * len(found)
    seen = set(np.concatenate([s.ids for s in world.steps]).tolist()) - {-1}
    assert set(found.ids[found.ids >= 0].tolist()) == seen
    assert np.sum(slam.best_map().ids < 0) < clutter / 10   # most clutter is gone entirely


def test_same_seed_same_estimate_and_different_seed_differs():
    world = make_world(seed=5, num_steps=80)
    results = []
    for seed in (7, 7, 8):
        slam = FastSLAM(config(seed=seed), initial_pose=world.steps[0].truth)
        run(slam, world)
        results.append(slam.poses.copy())
    np.testing.assert_array_equal(results[0], results[1])
    assert not np.allclose(results[0], results[2])


def test_covariances_stay_symmetric_positive_definite_and_finite():
    world = make_world(seed=6, num_steps=400, laps=3.0)
    slam = FastSLAM(config(algorithm="fastslam2"), initial_pose=world.steps[0].truth)
    run(slam, world)
    assert np.all(np.isfinite(slam.poses)) and np.all(np.isfinite(slam.log_weights))
    for particle in range(slam.num_particles):
        _, cov, _, _, _ = slam.particle_map(particle)
        xx, xy, yy = cov[:, 0], cov[:, 1], cov[:, 2]
        assert np.all(xx > 0) and np.all(xx * yy - xy * xy > 0)


def test_far_outliers_stay_finite_in_log_space_and_total_underflow_is_reported():
    slam = FastSLAM(config(association="known", num_particles=20), initial_pose=(0, 0, 0))
    slam.update([5.0], [0.0], [1])
    slam.predict((0, 0, 0), (0.1, 0, 0))
    # An observation 1e5 sigma away from the known landmark: a linear-space likelihood would
    # be exactly 0 for every particle; log weights stay finite.
    report = slam.update([5.0e4], [0.0], [1])
    assert not report.weights_underflow
    assert np.all(np.isfinite(slam.log_weights)) and np.all(np.isfinite(slam.poses))
    # If nothing finite is left (e.g. NaN from outside), weights reset to uniform, flagged.
    slam.log_weights = np.full(20, -np.inf)
    report = slam.update([5.0], [0.0], [1])
    assert report.weights_underflow and slam.num_underflows == 1
    np.testing.assert_allclose(slam.weights(), 1 / 20)


def test_best_path_follows_the_best_particle_and_grows_per_update():
    world = make_world(seed=7, num_steps=600, laps=3.0)
    slam = FastSLAM(config(), initial_pose=world.steps[0].truth)
    run(slam, world)
    stamps, poses = slam.best_path()
    assert len(stamps) == len(world.steps) - 1 == slam.num_updates
    np.testing.assert_array_equal(stamps, np.arange(len(stamps), dtype=float))
    np.testing.assert_allclose(poses[-1], slam.poses[slam.best_index()])
    truth = np.array([s.truth for s in world.steps[1:]])
    assert np.sqrt(np.mean(np.sum((poses[:, :2] - truth[:, :2]) ** 2, axis=1))) < 0.5
    # Shared ancestry: far fewer stored poses than one path per particle.
    assert len(slam.history) == slam.num_updates
    stored = len(slam.history._chain_poses) + sum(len(kept) for _, _, kept
                                                  in slam.history.generations())
    assert stored < 0.3 * slam.num_particles * slam.num_updates


def test_heaviest_best_particle_is_reported_and_kept_through_resampling():
    """Empty readings leave the weights as set here, so they alone decide the best particle."""
    poses = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], float)

    def reweigh(threshold, weights) -> FastSLAM:
        slam = FastSLAM(config(num_particles=4, resample_threshold=threshold,
                                  best_particle="heaviest"))
        slam.poses = poses.copy()
        slam.log_weights = np.log(np.asarray(weights, float))
        slam.resampled = slam.update([], []).resampled
        return slam

    plain = reweigh(0.1, [0.2, 0.5, 0.15, 0.15])
    assert not plain.resampled and plain.best_index() == 1
    # Resampling keeps the best particle as one of its copies (systematic resampling draws a
    # weight >= 1 / M at least once).
    every = reweigh(1.0, [0.2, 0.26, 0.34, 0.2])
    assert every.resampled
    np.testing.assert_allclose(every.best_pose(), poses[2])


def test_central_best_particle_is_nearest_the_weighted_mean_position():
    """Two heavy particles at the ends of the spread and a light one between them: the heaviest
    is an end, the central one the middle (closed form: the weighted mean is (1.9, 0.17))."""
    poses = np.array([[0, 0, 0.4], [4, 0, -0.4], [2, 0.2, 0], [2, 3, 0]], float)
    weights = np.array([0.45, 0.4, 0.1, 0.05])
    mean = weights @ poses[:, :2]
    np.testing.assert_allclose(mean, [1.9, 0.17])

    def filter_with(**changes) -> FastSLAM:
        slam = FastSLAM(config(num_particles=4, resample_threshold=0.1, **changes))
        slam.poses = poses.copy()
        slam.log_weights = np.log(weights)
        assert not slam.update([], []).resampled
        return slam

    assert filter_with(best_particle="heaviest").best_index() == 0
    central = filter_with(best_particle="central")
    assert central.best_index() == 2
    np.testing.assert_allclose(central.best_pose(), poses[2])
    # After resampling, the central particle of the drawn set. Weights in quarters draw
    # particles 0, 0, 1, 2 (systematic); the nearly weightless particle 3 sits on the mean
    # (1.5, 0.25), so it is central before and gone after: the drawn set's central one is 2.
    resampled = FastSLAM(config(num_particles=4, resample_threshold=1.0,
                                best_particle="central"))
    resampled.poses = np.array([[0, 0, 0], [4, 0, 0], [2, 1, 0], [1.5, 0.25, 0]], float)
    resampled.log_weights = np.log([0.5, 0.25, 0.25, 1e-12])
    assert resampled.update([], []).resampled
    np.testing.assert_allclose(np.sort(resampled.poses[:, 0]), [0, 0, 2, 4])
    np.testing.assert_allclose(resampled.best_pose(), [2, 1, 0])
    with pytest.raises(ValueError, match="best_particle"):
        config(best_particle="lightest")


def test_mean_pose_and_covariance_of_known_particles():
    slam = FastSLAM(config(num_particles=4), initial_pose=(0, 0, 0))
    slam.poses = np.array([[0, 0, np.pi - 0.1], [2, 0, -np.pi + 0.1], [0, 2, np.pi - 0.1],
                           [2, 2, -np.pi + 0.1]], float)
    mean, cov = slam.mean_pose_and_covariance()
    np.testing.assert_allclose(mean, [1, 1, np.pi], atol=1e-12)
    np.testing.assert_allclose(np.diag(cov), [1, 1, 0.01], atol=1e-12)


def test_pending_odometry_is_reported_but_not_yet_sampled():
    slam = FastSLAM(config(num_particles=5), initial_pose=(1.0, 2.0, 0.5))
    slam.predict((0, 0, 0), (0.2, 0.0, 0.1))
    np.testing.assert_allclose(slam.poses, np.tile([1.0, 2.0, 0.5], (5, 1)))
    expected = [1.0 + 0.2 * np.cos(0.5), 2.0 + 0.2 * np.sin(0.5), 0.6]
    np.testing.assert_allclose(slam.best_pose(), expected, atol=1e-12)
    # Beyond max_pending_translation, FastSLAM 2.0 moves the motion into its Gaussian prior
    # (the particles still read the same, the estimate follows the odometry) ...
    slam.predict((0.2, 0.0, 0.1), (2.0, 0.0, 0.1))
    np.testing.assert_allclose(slam.poses, np.tile([1.0, 2.0, 0.5], (5, 1)))
    moved = compose(np.array([1.0, 2.0, 0.5]), np.array([2.0, 0.0, 0.1]))
    np.testing.assert_allclose(slam.best_pose(), moved, atol=1e-12)
    # ... and FastSLAM 1.0 samples it at once.
    slam1 = FastSLAM(config(num_particles=5, algorithm="fastslam1"), initial_pose=(1.0, 2.0, 0.5))
    slam1.predict((0, 0, 0), (2.0, 0.0, 0.1))
    assert not np.allclose(slam1.poses, np.tile([1.0, 2.0, 0.5], (5, 1)))
    assert np.linalg.norm(slam1.best_pose() - moved) < 0.5


def test_known_id_seen_twice_in_one_reading_makes_one_landmark():
    slam = FastSLAM(config(association="known", num_particles=10), initial_pose=(0, 0, 0))
    report = slam.update([5.0, 5.05], [0.1, 0.1], [3, 3])
    found = slam.best_map()
    assert len(found) == 1 and found.ids[0] == 3
    assert list(report.is_new) == [True, False] and list(report.associated_ids) == [-1, 3]
    single = FastSLAM(config(association="known", num_particles=10), initial_pose=(0, 0, 0))
    single.update([5.0], [0.1], [3])
    # The second observation was fused: the covariance shrank below a single initialisation.
    assert np.linalg.det(found.covariances[0]) < 0.75 * np.linalg.det(
        single.best_map().covariances[0])


@pytest.mark.parametrize("association", ["ml", "monte_carlo", "known"])
def test_keeping_the_working_set_across_readings_changes_nothing(association):
    """The working set kept across readings (written back only when the robot reaches other
    cells) gives the same filter as writing it back after every reading, which is what the
    shared store alone would hold; the map read through ``particle_map`` is the stored one."""
    world = make_world(seed=3, num_steps=150, extent=40.0, num_landmarks=40, laps=1.5,
                       clutter_per_step=0.5)
    kept = FastSLAM(config(association=association, cell_size=4.0, max_range=8.0),
                    initial_pose=world.steps[0].truth)
    flushed = FastSLAM(config(association=association, cell_size=4.0, max_range=8.0),
                       initial_pose=world.steps[0].truth)
    gathers = []
    store_gather = kept.landmarks.gather
    kept.landmarks.gather = lambda *args, **kwargs: gathers.append(1) or store_gather(*args,
                                                                                    **kwargs)
    previous = world.steps[0].odometry
    for k, step in enumerate(world.steps[1:]):
        ids = step.ids if association == "known" else None
        keep = step.ids >= 0 if association == "known" else slice(None)
        for slam in (kept, flushed):
            slam.predict(previous, step.odometry)
            slam.update(step.ranges[keep], step.bearings[keep],
                        None if ids is None else ids[keep], stamp=float(k))
        flushed.flush()
        previous = step.odometry
        np.testing.assert_array_equal(kept.poses, flushed.poses)
        np.testing.assert_array_equal(kept.log_weights, flushed.log_weights)
        if k % 10 == 0:
            for particle in range(0, kept.num_particles, 7):
                mine, theirs = kept.particle_map(particle), flushed.particle_map(particle)
                order_mine, order_theirs = np.argsort(mine[4]), np.argsort(theirs[4])
                for a, b in zip(mine, theirs):
                    np.testing.assert_array_equal(a[order_mine], b[order_theirs])
    # The run exercised both paths: kept across readings and gathered anew.
    assert kept.num_updates - len(gathers) > 50 and len(gathers) > 3


def test_fastslam2_known_ids_without_outlier_model_weighs_like_the_scored_path():
    """Without an outlier model, FastSLAM 2.0 with known ids skips scoring the observations
    (the proposal's joint likelihood replaces their factors): the weights must equal those of
    the scored path (eps = 1e-300 takes it and changes nothing measurable), also where only
    some particles create a landmark (p0) because the others still hold it."""
    world = make_world(seed=8, num_steps=150, detection_probability=0.6)
    harsh = dict(algorithm="fastslam2", association="known", num_particles=30,
                 logodds_missed=-2.0, logodds_remove=-0.5, alpha1=0.05, alpha3=0.05)
    skipped = FastSLAM(config(**harsh, outlier_probability=0.0),
                       rng=np.random.default_rng(7), initial_pose=world.steps[0].truth)
    scored = FastSLAM(config(**harsh, outlier_probability=1e-300),
                      rng=np.random.default_rng(7), initial_pose=world.steps[0].truth)
    mixed = []
    previous = world.steps[0].odometry
    for k, step in enumerate(world.steps[1:]):
        keep = step.ids >= 0
        first_key = skipped.landmarks.next_key
        for slam in (skipped, scored):
            slam.predict(previous, step.odometry)
            slam.update(step.ranges[keep], step.bearings[keep], step.ids[keep], stamp=float(k))
        previous = step.odometry
        # Labels of the landmarks this reading created, per particle: mixed when some
        # particles created one that others already held.
        created = [frozenset(label[key >= first_key].tolist())
                   for _, _, _, label, key in map(skipped.particle_map, range(30))]
        mixed.append(frozenset.union(*created) != frozenset.intersection(*created))
        np.testing.assert_allclose(skipped.poses, scored.poses, atol=1e-9, rtol=0)
        np.testing.assert_allclose(skipped.log_weights, scored.log_weights, atol=1e-9, rtol=0)
    assert any(mixed)
