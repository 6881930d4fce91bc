# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The map lifecycle: a loaded map seeds every particle, localization keeps it fixed, a given
pose redraws the particles; in the core, in the node, and end to end at small scale."""
from __future__ import annotations

import argparse
import os
import tracemalloc

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.context import Context
from rclpy.parameter import Parameter
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from fastslam_ros import map_files, ros_io
from fastslam_ros.core import FastSLAM, FastSLAMConfig, LandmarkMap
from fastslam_ros.core.config import numba_available
from fastslam_ros.core.relocalization import MIN_PAIR_DISTANCE, find_pose
from fastslam_ros.node import FastSLAMNode, ParameterError
from fastslam_ros.tools.simulation.synthetic import make_world

DOMAIN_ID = 100 + os.getpid() % 100
CONFIG = FastSLAMConfig(num_particles=40, sigma_range=0.1, sigma_bearing=0.02, alpha1=0.01,
                        alpha2=0.0005, alpha3=0.01, alpha4=0.001, max_range=12.0,
                        new_landmark_likelihood=1e-3, seed=1)


def world():
    return make_world(seed=4, num_landmarks=30, extent=30.0, num_steps=120, max_range=12.0,
                      clutter_per_step=0.5)


def feed(slam: FastSLAM, steps) -> np.ndarray:
    """Run the steps; the position error (m) of the best particle after each."""
    previous, errors = steps[0].odometry, []
    for step in steps[1:]:
        slam.predict(previous, step.odometry)
        previous = step.odometry
        slam.update(step.ranges, step.bearings)
        errors.append(np.hypot(*(slam.best_pose()[:2] - step.truth[:2])))
    return np.array(errors)


def truth_map(landmarks: np.ndarray):
    count = len(landmarks)
    return landmarks, np.tile(np.eye(2) * 0.01, (count, 1, 1)), np.arange(count)


# --- core ----------------------------------------------------------------------------------

def test_localization_keeps_the_loaded_map_fixed_and_tracks_better_than_dead_reckoning():
    scene = world()
    means, covariances, ids = truth_map(scene.landmarks)
    slam = FastSLAM(CONFIG.replace(mode="localization"), initial_pose=scene.steps[0].truth)
    slam.seed_map(means, covariances, ids)
    errors = feed(slam, scene.steps)
    for particle in (0, slam.num_particles - 1):
        mean, packed, logodds, label, _ = slam.particle_map(particle)
        order = np.argsort(label)
        # No update, no removal, no clutter landmark: the map is exactly the loaded one.
        np.testing.assert_array_equal(mean[order], means)
        np.testing.assert_array_equal(packed[order][:, [0, 2]], np.full((len(means), 2), 0.01))
        assert np.all(logodds == logodds[0])
    drift = [np.hypot(*(s.odometry[:2] - s.truth[:2])) for s in scene.steps[1:]]
    assert errors.max() < 0.3 < max(drift)


def test_mapping_from_a_loaded_map_keeps_it_through_reset_and_adds_to_it():
    scene = world()
    slam = FastSLAM(CONFIG, initial_pose=scene.steps[0].truth)
    slam.seed_map(*truth_map(scene.landmarks[:10]))
    assert len(slam.best_map()) == 10
    feed(slam, scene.steps[:40])
    assert len(slam.best_map()) > 10
    slam.reset(scene.steps[0].truth)
    np.testing.assert_allclose(np.sort(slam.best_map().means[:, 0]),
                               np.sort(scene.landmarks[:10, 0]))


def test_initialize_pose_draws_the_particles_from_the_given_gaussian():
    slam = FastSLAM(CONFIG.replace(num_particles=4000))
    mean = np.array([2.0, -1.0, 3.0])
    covariance = np.array([[0.5, 0.1, 0.0], [0.1, 0.2, 0.02], [0.0, 0.02, 0.05]])
    slam.initialize_pose(mean, covariance)
    poses = slam.particle_poses()
    offsets = poses - mean
    offsets[:, 2] = np.arctan2(np.sin(offsets[:, 2]), np.cos(offsets[:, 2]))
    # 4,000 draws: the sample mean within ~4 standard errors, the covariance within 10 %.
    assert np.all(np.abs(offsets.mean(axis=0)) < 4.0 * np.sqrt(np.diag(covariance) / 4000))
    np.testing.assert_allclose(np.cov(offsets.T), covariance, atol=0.1 * 0.5)
    np.testing.assert_allclose(slam.weights(), 1.0 / 4000)


def test_localization_from_a_wrong_pose_converges_with_its_covariance():
    scene = world()
    slam = FastSLAM(CONFIG.replace(mode="localization", num_particles=500),
                    initial_pose=scene.steps[0].truth)
    slam.seed_map(*truth_map(scene.landmarks))
    start = scene.steps[0].truth
    slam.initialize_pose(start + [1.4, 1.4, 0.5], np.diag([2.0, 2.0, 0.25]))
    assert np.hypot(*(slam.particle_poses()[:, :2].mean(axis=0) - start[:2])) > 1.5
    errors = feed(slam, scene.steps)
    assert errors[-60:].max() < 0.3


def test_find_pose_recovers_the_pose_from_one_reading_among_clutter():
    rng = np.random.default_rng(3)
    landmarks = rng.uniform(-30.0, 30.0, (40, 2))
    pose = np.array([12.3, -4.1, 2.0])
    c, s = np.cos(pose[2]), np.sin(pose[2])
    visible = landmarks[np.hypot(*(landmarks - pose[:2]).T) < 15.0]
    # Robot frame: R(-theta) (m - p), with 5 cm noise; two clutter points.
    points = (visible - pose[:2]) @ np.array([[c, -s], [s, c]]) + rng.normal(0, 0.05,
                                                                              visible.shape)
    points = np.vstack([points, [[3.0, 7.0], [-9.0, 1.5]]])
    found, inliers = find_pose(points, landmarks, 0.5)
    assert inliers == len(visible) >= 4
    assert np.hypot(*(found[:2] - pose[:2])) < 0.1
    assert abs(np.angle(np.exp(1j * (found[2] - pose[2])))) < 0.01
    close = np.array([[1.0, 0.0], [1.0, 0.5 * MIN_PAIR_DISTANCE]])
    assert find_pose(close, landmarks, 0.5)[1] == 0


def kidnapped_errors(config: FastSLAMConfig, offset=(4.0, -3.0, 0.6),
                     sigmas=(0.01, 0.01, 0.001), given: bool = False) -> tuple[np.ndarray, int]:
    """Localize on the true map; after 40 readings (0.2 s apart) the particles are redrawn
    around a pose ``offset`` (m, m, rad) off (standard deviations ``sigmas``; by default the
    filter is made certain of a pose 5 m and 0.6 rad off): by the filter itself (a loss), or
    with ``given`` as a user's ``initialize_pose``; the best particle's position errors after
    that and the number of relocalizations."""
    scene = world()
    slam = FastSLAM(config.replace(mode="localization"), initial_pose=scene.steps[0].truth)
    slam.seed_map(*truth_map(scene.landmarks))
    previous, errors = scene.steps[0].odometry, []
    for index, step in enumerate(scene.steps[1:], start=1):
        slam.predict(previous, step.odometry)
        previous = step.odometry
        if index == 40:
            mean, covariance = step.truth + offset, np.diag(np.square(sigmas))
            if given:
                slam.initialize_pose(mean, covariance)
            else:
                slam.poses = mean + np.asarray(sigmas) * slam.rng.standard_normal(
                    (slam.num_particles, 3))
        slam.update(step.ranges, step.bearings, stamp=0.2 * index)
        if index > 40:
            errors.append(np.hypot(*(slam.best_pose()[:2] - step.truth[:2])))
    return np.array(errors), slam.num_relocalizations


def test_localization_finds_its_pose_again_after_a_kidnap():
    config = CONFIG.replace(relocalization_delay=1.0)
    errors, relocalizations = kidnapped_errors(config)
    # Lost for the delay (five readings), then found from a reading: tracking again.
    assert relocalizations >= 1
    assert errors[-40:].max() < 0.3
    stuck, never = kidnapped_errors(config.replace(relocalization_fraction=0.0))
    assert never == 0
    assert stuck[-40:].min() > 1.0


@pytest.mark.skipif(not numba_available(), reason="numba is not installed (the fast extra)")
def test_relocalization_is_the_same_on_both_backends():
    """The pose search runs after either backend's reading: the same redraws, the same path."""
    config = CONFIG.replace(relocalization_delay=1.0)
    errors, count = kidnapped_errors(config.replace(backend="numpy"))
    compiled, compiled_count = kidnapped_errors(config.replace(backend="numba"))
    assert count == compiled_count >= 1
    np.testing.assert_allclose(compiled, errors, atol=1e-9)


def test_a_pose_search_over_a_dense_reading_and_map_stays_small():
    """60 observations against 120 landmarks: the search pairs and scores a bounded share of
    the observations, so its memory stays far below what all pairs take (about 600 MB here,
    growing with the square of both)."""
    rng = np.random.default_rng(5)
    landmarks = rng.uniform(-30.0, 30.0, (120, 2))
    pose = np.array([1.0, -2.0, 0.4])
    c, s = np.cos(pose[2]), np.sin(pose[2])
    points = (landmarks[:60] - pose[:2]) @ np.array([[c, -s], [s, c]])
    tracemalloc.start()
    found, inliers = find_pose(points, landmarks, 0.5)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 100 * 2**20
    assert inliers == 60
    np.testing.assert_allclose(found, pose, atol=1e-6)


def test_a_loss_that_drifts_away_from_the_found_pose_is_not_waited_out():
    """Certain of a pose 5 m and 0.6 rad off, the filter follows the odometry in a turned
    frame, away from the pose the readings give: it is redrawn there long before the delay
    (the kidnap lasts 16 s) and tracks the truth again."""
    errors, relocalizations = kidnapped_errors(CONFIG.replace(relocalization_delay=100.0))
    assert relocalizations >= 1
    assert errors[-40:].max() < 0.3


LOSS = ((3.0, 0.0, 0.1), (0.5, 0.5, 0.05))
"""A loss that keeps its distance to the pose the readings give: offset and spread (m, m, rad)."""


def test_a_loss_that_keeps_its_distance_to_the_found_pose_is_waited_out(monkeypatch):
    """The filter's own loss, 3 m off along the heading, with a spread that does not reach
    the truth: lost and searching, but the found pose stays within a gate of the closest one,
    so nothing is redrawn before the delay; without the delay the same loss is ended."""
    from fastslam_ros.core import relocalization
    searches = []

    def counted(*args):
        searches.append(args)
        return find_pose(*args)
    monkeypatch.setattr(relocalization, "find_pose", counted)
    offset, sigmas = LOSS
    _, waited = kidnapped_errors(CONFIG.replace(relocalization_delay=100.0), offset, sigmas)
    assert waited == 0 and len(searches) >= 5
    _, ended = kidnapped_errors(CONFIG.replace(relocalization_delay=0.0), offset, sigmas)
    assert ended >= 1


def test_a_given_pose_off_the_map_is_corrected_at_the_first_search():
    """The same loss as above, but from an initialpose: a pose the user guessed, not a filter
    that may find the map by itself; the pose the reading gives is taken at once."""
    config = CONFIG.replace(relocalization_delay=100.0)
    errors, relocalizations = kidnapped_errors(config, *LOSS, given=True)
    assert relocalizations == 1
    assert errors[:3].max() < 0.5 and errors[-40:].max() < 0.3
    waited, none = kidnapped_errors(config, *LOSS)
    assert none == 0 and waited[:3].min() > 2.0


def test_a_pose_search_that_finds_nothing_waits_before_the_next(monkeypatch):
    from fastslam_ros.core import relocalization
    searches = []

    def counted(*args):
        searches.append(args)
        return find_pose(*args)
    monkeypatch.setattr(relocalization, "find_pose", counted)
    scene = world()
    slam = FastSLAM(CONFIG.replace(mode="localization", relocalization_delay=0.0),
                    initial_pose=scene.steps[0].truth)
    # A map with nothing where the robot is: every reading is lost, no pose is found.
    slam.seed_map(*truth_map(scene.landmarks + 500.0))
    for index, step in enumerate(scene.steps[1:51], start=1):
        slam.update(step.ranges, step.bearings, stamp=0.2 * index)
    # 50 lost readings over 10 s: one search per RELOCALIZATION_RETRY s, not one per reading.
    assert slam.num_relocalizations == 0
    assert len(searches) == 10


# --- the map a user sees ------------------------------------------------------------------

def test_confirmed_keeps_the_landmarks_at_least_that_likely_to_exist():
    existence = np.array([0.2, 0.73, 0.9, 0.99])
    landmark_map = LandmarkMap(np.arange(8.0).reshape(4, 2), np.tile(np.eye(2), (4, 1, 1)),
                               existence, np.array([5, -1, 7, 8]), np.array([10, 11, 12, 13]))
    shown = landmark_map.confirmed(0.9)
    np.testing.assert_array_equal(shown.keys, [12, 13])
    np.testing.assert_array_equal(shown.ids, [7, 8])
    np.testing.assert_array_equal(shown.means, [[4.0, 5.0], [6.0, 7.0]])
    assert len(landmark_map.confirmed(0.0)) == 4 and len(landmark_map.confirmed(1.0)) == 0


def test_a_new_landmark_is_tentative_until_seen_again():
    """Seen once, a landmark has log-odds logodds_observed (existence 0.73 < 0.9): the filter
    keeps it, the map a user sees does not; seen three times (log-odds 3, 0.95) it shows."""
    config = FastSLAMConfig(num_particles=10, seed=1)
    assert config.map_min_existence == 0.9
    slam = FastSLAM(config)
    for seen in (1, 2, 3):
        slam.update(np.array([5.0]), np.array([0.3]))
        existence = 1.0 / (1.0 + np.exp(-config.logodds_observed * seen))
        np.testing.assert_allclose(slam.best_map().existence, [existence])
        shown = slam.best_map(config.map_min_existence)
        assert len(shown) == (1 if existence >= config.map_min_existence else 0)
    assert len(shown) == 1


# --- map files -----------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".yaml", ".csv"])
def test_a_saved_map_reads_back(tmp_path, suffix):
    saved = LandmarkMap(np.array([[1.0, 2.0], [-3.0, 1e-5]]),
                        np.array([[[0.2, 0.01], [0.01, 0.1]], [[1e-5, 0.0], [0.0, 2e-5]]]),
                        np.array([0.9, 0.6]), np.array([7, -1]), np.array([0, 1]))
    path = map_files.write_map_file(tmp_path / f"map{suffix}", saved, "map", 3.0)
    loaded = map_files.read_map_file(path)
    np.testing.assert_allclose(loaded.means, saved.means)
    np.testing.assert_allclose(loaded.covariances, saved.covariances)
    np.testing.assert_array_equal(loaded.ids, saved.ids)
    assert loaded.frame_id == ("map" if suffix == ".yaml" else "")


@pytest.mark.parametrize("text", ["landmarks: [{x: 1}]", "- 1", "landmarks: [", ""])
def test_a_bad_map_file_is_named(tmp_path, text):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(map_files.MapFileError, match="bad.yaml"):
        map_files.read_map_file(path)
    with pytest.raises(map_files.MapFileError, match="No such file"):
        map_files.read_map_file(tmp_path / "absent.yaml")


# --- node ----------------------------------------------------------------------------------

@pytest.fixture
def context():
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID)
    yield ctx
    rclpy.shutdown(context=ctx)


def saved_map(tmp_path, count: int = 5):
    means = np.column_stack([np.arange(count, dtype=float), np.ones(count)])
    landmark_map = LandmarkMap(means, np.tile(np.eye(2) * 0.01, (count, 1, 1)), np.ones(count),
                               np.arange(count) + 10, np.arange(count))
    return map_files.write_map_file(tmp_path / "map.yaml", landmark_map, "map", 0.0, overwrite=True)


def node_with(context, **values) -> FastSLAMNode:
    return FastSLAMNode(context=context, parameter_overrides=[
        Parameter(name, value=value) for name, value in {"num_particles": 20, "seed": 1,
                                                         "use_sim_time": True,
                                                         **values}.items()])


def test_node_loads_the_map_at_start_and_on_load_map(context, tmp_path):
    path = saved_map(tmp_path)
    node = node_with(context, map_file=str(path), mode="localization")
    try:
        assert len(node.slam.best_map()) == 5
        np.testing.assert_array_equal(np.sort(node.slam.best_map().ids), np.arange(5) + 10)
        saved_map(tmp_path, count=3)
        response = node._on_load_map(Trigger.Request(), Trigger.Response())
        assert response.success and "3 landmarks" in response.message
        assert len(node.slam.best_map()) == 3
        path.write_text("landmarks: [")
        response = node._on_load_map(Trigger.Request(), Trigger.Response())
        assert not response.success and "map.yaml" in response.message
        assert len(node.slam.best_map()) == 3  # a failed load keeps the map
    finally:
        node.destroy_node()


@pytest.mark.parametrize("values, named", [
    ({"map_file": "/nonexistent/map.yaml"}, "'map_file'"),
    ({"mode": "localization"}, "'mode', 'map_file'"),
    ({"mode": "slam"}, "'mode'"),
])
def test_node_start_fails_naming_the_map_parameters(context, values, named):
    with pytest.raises(ParameterError, match=named):
        node_with(context, **values)


def initial_pose(frame: str, pose, sigma: float) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped(header=Header(frame_id=frame))
    msg.pose.pose = ros_io.pose_msg(pose)
    covariance = np.zeros((6, 6))
    covariance[[0, 1, 5], [0, 1, 5]] = sigma ** 2
    msg.pose.covariance = covariance.ravel().tolist()
    return msg


def test_node_initial_pose_redraws_the_particles_before_and_after_odometry(context):
    from nav_msgs.msg import Odometry
    node = node_with(context)
    try:
        node.on_initial_pose(initial_pose("map", (5.0, -2.0, 1.0), 0.01))
        odometry = Odometry(header=Header(frame_id="odom"), child_frame_id="base_link")
        odometry.pose.pose.orientation.w = 1.0
        node.on_odometry(odometry)  # the first odometry keeps the pose given before it
        np.testing.assert_allclose(node.slam.particle_poses().mean(axis=0), [5.0, -2.0, 1.0],
                                   atol=0.02)
        node.on_initial_pose(initial_pose("map", (-1.0, 3.0, -0.5), 0.01))
        np.testing.assert_allclose(node.slam.particle_poses().mean(axis=0), [-1.0, 3.0, -0.5],
                                   atol=0.02)
        node.on_initial_pose(initial_pose("odom", (9.0, 9.0, 0.0), 0.01))
        node.on_initial_pose(initial_pose("map", (9.0, 9.0, 0.0), float("nan")))
        assert node.stats["initial_poses"] == 2
        assert node.stats["dropped_wrong_frame"] == 1 and node.stats["dropped_nan"] == 1
    finally:
        node.destroy_node()


# --- end to end ----------------------------------------------------------------------------

def test_a_saved_map_localizes_a_second_run_of_the_same_world(tmp_path):
    """fastslam-sim, 15 s: map, save, then localize a second run on the map (the full-size
    figures: python3 -m fastslam_ros.tools.benchmarks.localization_bench)."""
    from fastslam_ros.tools.benchmarks.localization_bench import run_seed
    args = argparse.Namespace(duration=15.0, offset=2.0, yaw_offset=0.5, start_sigma=1.0,
                              start_yaw_sigma=0.2, converged=0.5)
    result = run_seed(2, tmp_path, args)
    assert result.localization_ate < result.mapping_ate
    assert result.convergence_time < 10.0


def test_node_counts_relocalizations(context, tmp_path):
    from fastslam_ros.node import Observation
    node = node_with(context, map_file=str(saved_map(tmp_path)), mode="localization",
                     relocalization_delay=0.0)
    try:
        # The map's landmarks (0..4, 1) seen from the origin; the particles sure of (20, 20).
        # The robot stands still.
        from nav_msgs.msg import Odometry
        node.on_initial_pose(initial_pose("map", (20.0, 20.0, 0.0), 0.01))
        for stamp in (0.5, 1.5):
            odometry = Odometry(header=Header(frame_id="odom", stamp=ros_io.seconds_to_stamp(
                stamp)), child_frame_id="base_link")
            odometry.pose.pose.orientation.w = 1.0
            node.on_odometry(odometry)
        offsets = np.column_stack([np.arange(5.0), np.ones(5)])
        node._update(Observation(1.0, np.hypot(*offsets.T), np.arctan2(offsets[:, 1],
                                                                       offsets[:, 0]), None, 0.0))
        assert node.slam.num_relocalizations == node.stats["relocalizations"] == 1
        # Redrawn at the landmarks (0.5 m spread; a line of landmarks also fits the pose
        # mirrored across it, 2 m away), not 28 m off.
        assert np.hypot(*node.slam.best_pose()[:2]) < 3.0
    finally:
        node.destroy_node()
