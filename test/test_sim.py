"""Simulator: determinism, vehicle kinematics, observation geometry, scenarios."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fastslam_ros.core import FastSLAMConfig
from fastslam_ros.tools.sim import SimConfig, build_world, recommended_params, simulate


def test_same_seed_same_bag_other_seed_other_noise():
    first = simulate(SimConfig(duration=10.0, seed=5))
    again = simulate(SimConfig(duration=10.0, seed=5))
    other = simulate(SimConfig(duration=10.0, seed=6))
    np.testing.assert_array_equal(first.odometry.poses, again.odometry.poses)
    for a, b in zip(first.scans.points, again.scans.points):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(first.odometry.poses, other.odometry.poses)
    np.testing.assert_array_equal(first.ground_truth.poses, other.ground_truth.poses)


def test_rates_speed_and_noise_free_odometry():
    config = SimConfig(duration=12.0, sigma_speed=0.0, sigma_steer=0.0)
    bag = simulate(config)
    assert len(bag.odometry.stamps) == 12 * 40 + 1
    # Stamps are dated like a recording's (float64 seconds there resolve 0.24 us).
    assert bag.odometry.stamps[0] == config.start_time == 1_700_000_000.0
    assert bag.scans.stamps[0] == pytest.approx(config.start_time + 0.2, abs=1e-6)
    np.testing.assert_allclose(np.diff(bag.odometry.stamps), 1 / 40, rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.diff(bag.scans.stamps), 1 / 5, rtol=0, atol=1e-6)
    step = np.linalg.norm(np.diff(bag.ground_truth.poses[:, :2], axis=0), axis=1)
    np.testing.assert_allclose(step, 3.0 / 40, rtol=1e-6)
    # Without control noise the odometry is the true path.
    np.testing.assert_allclose(bag.odometry.poses, bag.ground_truth.poses, atol=1e-9)


def test_noisy_odometry_drifts_from_the_truth():
    bag = simulate(SimConfig(duration=60.0))
    drift = np.linalg.norm(bag.odometry.poses[-1, :2] - bag.ground_truth.poses[-1, :2])
    assert drift > 0.1


def test_observations_are_landmarks_seen_from_the_true_pose():
    config = SimConfig(duration=8.0, sigma_range=1e-9, sigma_bearing=1e-9)
    bag = simulate(config)
    truth = dict(zip(bag.landmarks_truth.ids.tolist(), bag.landmarks_truth.positions))
    index_of = {round(t * 40): i for i, t in enumerate(bag.ground_truth.stamps)}
    checked = 0
    for stamp, points, ids in zip(bag.scans.stamps, bag.scans.points, bag.scans.ids):
        x, y, theta = bag.ground_truth.poses[index_of[round(stamp * 40)]]
        c, s = math.cos(theta), math.sin(theta)
        world = np.stack([x + c * points[:, 0] - s * points[:, 1],
                          y + s * points[:, 0] + c * points[:, 1]], axis=1)
        expected = np.array([truth[i] for i in ids]).reshape(-1, 2)
        np.testing.assert_allclose(world, expected, atol=1e-4)
        visible = np.linalg.norm(bag.landmarks_truth.positions - (x, y), axis=1) <= 30.0
        assert len(ids) == np.count_nonzero(visible)
        checked += len(ids)
    assert checked > 50


def test_clutter_scenario_has_false_and_missed_detections():
    clean = simulate(SimConfig(scenario="loop", duration=30.0))
    cluttered = simulate(SimConfig(scenario="clutter", duration=30.0))
    clutter_count = sum(np.count_nonzero(ids == -1) for ids in cluttered.scans.ids)
    labelled = sum(np.count_nonzero(ids >= 0) for ids in cluttered.scans.ids)
    assert clutter_count > 0.5 * 2.0 * len(cluttered.scans.stamps)
    assert labelled < sum(len(ids) for ids in clean.scans.ids)
    assert all(np.all(ids >= 0) for ids in clean.scans.ids)


def test_large_world_has_thousands_of_separated_landmarks():
    world = build_world(SimConfig(scenario="large").resolved())
    positions = world.landmarks.positions
    assert len(positions) >= 1000
    assert len(np.unique(world.landmarks.ids)) == len(positions)
    sample = positions[:300]
    distance = np.linalg.norm(sample[:, None] - positions[None], axis=2)
    np.fill_diagonal(distance[:, :300], np.inf)
    assert distance.min() >= 4.0


def test_recommended_params_are_valid_core_settings():
    core_fields = {item.name for item in dataclasses.fields(FastSLAMConfig)}
    for scenario in ("loop", "large", "clutter"):
        params = recommended_params(SimConfig(scenario=scenario))
        FastSLAMConfig(**{k: v for k, v in params.items() if k in core_fields}).validate()
        assert set(params) - core_fields == {"pose_estimate", "markers_rate", "path_rate",
                                             "particles_rate"}
        assert params["sigma_bearing"] == pytest.approx(math.radians(1.0))


def test_bad_settings_are_rejected_by_name():
    with pytest.raises(ValueError, match="speed"):
        simulate(SimConfig(speed=0.0))
    with pytest.raises(ValueError, match="scenario"):
        simulate(SimConfig(scenario="moon"))


def test_written_parameter_file_applies_under_any_namespace(tmp_path):
    from fastslam_ros.node import read_params_file
    from fastslam_ros.tools.sim import write_params_yaml
    params = recommended_params(SimConfig().resolved())
    path = write_params_yaml(tmp_path / "sim.yaml", params, "Recommended\nparameters")
    assert path.read_text().startswith("# Recommended\n# parameters\n/**:\n")
    assert read_params_file(path, "/robot1/fastslam") == pytest.approx(params)
