# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""World generator and simulator: sensor and odometry statistics, determinism, vehicle
kinematics, observation geometry, scenarios, the in-memory synthetic worlds; the people
simulator's crowd (solid bodies that pass each other, off the walls, never deadlocked)."""
from __future__ import annotations

import dataclasses
import math
from collections import deque

import numpy as np
import pytest

from fastslam_ros.core import FastSLAMConfig
from fastslam_ros.tools.bags.bag_schema import LandmarkSet
from fastslam_ros.core.geometry import relative_pose
from fastslam_ros.core.observation import inverse_observe
from fastslam_ros.tools.simulation import crowd as crowd_model
from fastslam_ros.tools.simulation.sim import (SimConfig, World, build_world, landmarks_in_range,
                                               recommended_params, simulate)
from fastslam_ros.tools.simulation.synthetic import make_world
from fastslam_ros.tools.simulation.world import (RangeBearingSensor, circle_path,
                                                 odometry_with_noise, scatter_landmarks)


def within_standard_errors(samples: np.ndarray, expected: float, spread: float,
                           errors: float = 4.0) -> bool:
    """Whether the sample mean is within ``errors`` standard errors of ``expected``."""
    return abs(np.mean(samples) - expected) <= errors * spread / math.sqrt(len(samples))


@pytest.mark.parametrize("spread", ["area", "range"])
def test_sensor_detects_within_reach_with_its_noise_detection_rate_and_clutter(spread):
    sensor = RangeBearingSensor(max_range=10.0, sigma_range=0.2, sigma_bearing=0.05,
                                detection_probability=0.7, clutter_rate=1.5,
                                clutter_spread=spread)
    # 24 landmarks at 3-8 m (in reach) all round, 24 at 12-17 m (out of reach).
    angles = np.linspace(-math.pi, math.pi, 48, endpoint=False)
    distances = np.where(np.arange(48) % 2 == 0, 3.0, 12.0) + 5.0 * (np.arange(48) % 5) / 4
    pose = np.array([1.0, -2.0, 2.5])
    landmarks = pose[:2] + distances[:, None] * np.column_stack([np.cos(angles),
                                                                 np.sin(angles)])
    rng = np.random.default_rng(3)
    readings = [sensor.observe(pose, landmarks, rng) for _ in range(2000)]
    labels = np.concatenate([r.labels for r in readings])
    ranges = np.concatenate([r.ranges for r in readings])
    bearings = np.concatenate([r.bearings for r in readings])
    assert np.all(ranges > 0.0) and np.all(ranges <= 10.0)
    assert np.all(bearings > -math.pi) and np.all(bearings <= math.pi)
    detected = labels[labels >= 0]
    assert set(detected.tolist()) == set(np.flatnonzero(distances <= 10.0).tolist())
    # Detection: binomial with p = 0.7 per landmark in reach and reading.
    hits = np.bincount(detected, minlength=48)[distances <= 10.0] / len(readings)
    assert within_standard_errors(hits, 0.7, math.sqrt(0.7 * 0.3 / len(readings)))
    # Noise: residuals against the true range and bearing (sensor at the vehicle's origin).
    offset = landmarks[detected] - pose[:2]
    range_error = ranges[labels >= 0] - np.hypot(offset[:, 0], offset[:, 1])
    bearing_error = np.angle(np.exp(1j * (bearings[labels >= 0] - np.arctan2(
        offset[:, 1], offset[:, 0]) + pose[2])))
    assert within_standard_errors(range_error, 0.0, 0.2)
    assert within_standard_errors(bearing_error, 0.0, 0.05)
    assert np.std(range_error) == pytest.approx(0.2, rel=0.03)
    assert np.std(bearing_error) == pytest.approx(0.05, rel=0.03)
    # Clutter: Poisson(1.5) per reading, evenly over the disc (E (r/R)^2 = 1/2) or over range
    # (E r/R = 1/2), bearings evenly all round.
    counts = np.array([np.count_nonzero(r.labels < 0) for r in readings])
    assert within_standard_errors(counts, 1.5, math.sqrt(1.5))
    clutter_range = ranges[labels < 0] / 10.0
    spread_measure = clutter_range**2 if spread == "area" else clutter_range
    assert within_standard_errors(spread_measure, 0.5, math.sqrt(1.0 / 12.0))
    assert within_standard_errors(bearings[labels < 0], 0.0, math.pi / math.sqrt(3.0))
    with pytest.raises(ValueError, match="clutter_spread"):
        RangeBearingSensor(10.0, 0.2, 0.05, clutter_spread="volume")


def test_sensor_with_a_field_of_view_sees_and_reports_clutter_only_in_its_opening():
    sensor = RangeBearingSensor(max_range=10.0, sigma_range=0.0, sigma_bearing=0.0,
                                clutter_rate=2.0, field_of_view=math.pi / 2)
    # Landmarks at 5 m every 15 degrees: those within 45 degrees of the heading are in view.
    angles = np.radians(np.arange(-180, 180, 15))
    pose = np.array([2.0, 1.0, -2.8])
    landmarks = pose[:2] + 5.0 * np.column_stack([np.cos(angles + pose[2]),
                                                  np.sin(angles + pose[2])])
    rng = np.random.default_rng(5)
    readings = [sensor.observe(pose, landmarks, rng) for _ in range(500)]
    labels = np.concatenate([r.labels for r in readings])
    bearings = np.concatenate([r.bearings for r in readings])
    in_view = np.flatnonzero(np.abs(angles) <= math.pi / 4 + 1e-9)
    assert set(labels[labels >= 0].tolist()) == set(in_view.tolist())
    np.testing.assert_allclose(bearings[labels >= 0], angles[labels[labels >= 0]], atol=1e-9)
    # Clutter: Poisson(2) per reading, bearings evenly over the opening (variance w^2 / 12).
    clutter = bearings[labels < 0]
    assert np.all(np.abs(clutter) <= math.pi / 4)
    assert within_standard_errors(np.array([np.count_nonzero(r.labels < 0) for r in readings]),
                                  2.0, math.sqrt(2.0))
    assert within_standard_errors(clutter, 0.0, (math.pi / 2) / math.sqrt(12.0))
    with pytest.raises(ValueError, match="field_of_view"):
        RangeBearingSensor(10.0, 0.2, 0.05, field_of_view=0.0)


def test_odometry_model_noise_has_its_stated_spread_and_none_gives_the_truth():
    truth = circle_path(radius=5.0, num_steps=4000, laps=20.0)
    # The circle: constant radius, chords of 2 r sin(d/2), heading along the circle's tangent.
    np.testing.assert_allclose(np.hypot(truth[:, 0], truth[:, 1]), 5.0)
    step_angle = 2.0 * math.pi * 20.0 / 4000
    delta = relative_pose(truth[:-1], truth[1:])
    np.testing.assert_allclose(np.hypot(delta[:, 0], delta[:, 1]),
                               10.0 * math.sin(step_angle / 2))
    np.testing.assert_allclose(delta[:, 2], step_angle)
    np.testing.assert_allclose(np.arctan2(delta[:, 1], delta[:, 0]), step_angle / 2)
    rng = np.random.default_rng(2)
    exact = odometry_with_noise(truth, (0.0, 0.0, 0.0), rng)
    np.testing.assert_allclose(relative_pose(truth, exact), 0.0, atol=1e-9)
    noise = (0.02, 0.1, 0.03)
    odometry = odometry_with_noise(truth, noise, rng)
    np.testing.assert_array_equal(odometry[0], truth[0])
    measured = relative_pose(odometry[:-1], odometry[1:])
    rot1 = np.arctan2(measured[:, 1], measured[:, 0])
    errors = [rot1 - step_angle / 2,
              np.hypot(measured[:, 0], measured[:, 1]) / (10.0 * math.sin(step_angle / 2)) - 1,
              np.angle(np.exp(1j * (measured[:, 2] - rot1))) - step_angle / 2]
    for error, sigma in zip(errors, noise):
        assert within_standard_errors(error, 0.0, sigma)
        assert np.std(error) == pytest.approx(sigma, rel=0.05)


def test_scattered_landmarks_are_in_the_box_accepted_and_apart():
    rng = np.random.default_rng(1)
    points = scatter_landmarks(rng, 150, (-10.0, 0.0), (10.0, 20.0), 1.0,
                               accept=lambda p: p[:, 0] > p[:, 1] - 10.0)
    assert points.shape == (150, 2)
    assert np.all((points >= (-10.0, 0.0)) & (points <= (10.0, 20.0)))
    assert np.all(points[:, 0] > points[:, 1] - 10.0)
    distance = np.linalg.norm(points[:, None] - points[None], axis=2)
    np.fill_diagonal(distance, np.inf)
    assert distance.min() >= 1.0
    with pytest.raises(ValueError, match="cannot place 500 landmarks"):
        scatter_landmarks(rng, 500, (0.0, 0.0), (5.0, 5.0), 1.0)


def test_synthetic_world_observes_its_landmarks_from_the_true_path():
    world = make_world(seed=2, num_steps=120, sigma_range=1e-9, sigma_bearing=1e-9)
    checked = 0
    for step in world.steps:
        in_reach = np.hypot(*(world.landmarks - step.truth[:2]).T) <= 12.0
        np.testing.assert_array_equal(np.sort(step.ids), np.flatnonzero(in_reach))
        np.testing.assert_allclose(inverse_observe(step.truth, step.ranges, step.bearings),
                                   world.landmarks[step.ids], atol=1e-6)
        checked += len(step.ids)
    assert checked > 500
    # Own streams: other sensor settings leave the landmarks and the path as they were.
    cluttered = make_world(seed=2, num_steps=120, clutter_per_step=1.0,
                           detection_probability=0.5)
    np.testing.assert_array_equal(cluttered.landmarks, world.landmarks)
    for a, b in zip(cluttered.steps, world.steps):
        np.testing.assert_array_equal(a.odometry, b.odometry)
    assert any(np.any(s.ids < 0) for s in cluttered.steps)
    other = make_world(seed=3, num_steps=120)
    assert not np.array_equal(other.landmarks, world.landmarks)


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


def test_clusters_world_groups_its_landmarks_in_twos_and_threes_a_few_decimetres_apart():
    """Every landmark of the clusters world has a neighbour 0.18-0.25 m away (MRCLAM's
    barcode tubes) and at most two within 0.5 m; the clusters keep the loop's spacing."""
    for world_seed in range(5):
        check_clusters(SimConfig(scenario="clusters", world_seed=world_seed).resolved())


def check_clusters(config: SimConfig) -> None:
    """The clusters world of ``config`` as ``test_clusters_world_...`` states it."""
    positions = build_world(config).landmarks.positions
    assert len(positions) == config.num_landmarks == 210
    distance = np.linalg.norm(positions[:, None] - positions[None], axis=2)
    np.fill_diagonal(distance, np.inf)
    assert np.all((distance.min(axis=1) >= 0.18 - 1e-9) & (distance.min(axis=1) <= 0.5))
    in_cluster = (distance < 0.5).sum(axis=1)
    assert set(in_cluster.tolist()) == {1, 2}
    # Union of the within-0.5 m pairs: the clusters, 2-3 each, 4 m apart (min_separation).
    groups = {frozenset(np.flatnonzero(distance[i] < 0.5).tolist() + [i])
              for i in range(len(positions))}
    assert {len(group) for group in groups} <= {2, 3} and sum(map(len, groups)) == 210
    firsts = np.array([positions[min(group)] for group in groups])
    apart = np.linalg.norm(firsts[:, None] - firsts[None], axis=2)
    np.fill_diagonal(apart, np.inf)
    assert apart.min() >= 4.0 - 2 * 0.25


def test_recommended_params_are_valid_core_settings():
    core_fields = {item.name for item in dataclasses.fields(FastSLAMConfig)}
    for scenario in ("loop", "large", "clutter", "clusters"):
        params = recommended_params(SimConfig(scenario=scenario))
        FastSLAMConfig(**{k: v for k, v in params.items() if k in core_fields}).validate()
        assert set(params) - core_fields == {"pose_estimate", "markers_rate", "path_rate",
                                             "particles_rate"}
        assert params["sigma_bearing"] == pytest.approx(math.radians(1.0))
        assert "field_of_view" not in params
    narrow = recommended_params(SimConfig(scenario="clutter", max_range=15.0,
                                          field_of_view=math.pi))
    assert (narrow["max_range"], narrow["field_of_view"]) == (15.0, math.pi)


def test_a_dense_world_is_recommended_neither_loop_closure_nor_the_smoother():
    """Worlds with more than ``DENSE_IN_RANGE`` landmarks in sensor range close false loops
    (the large world: docs/benchmarks.md) whatever their scenario: the loop with 600
    landmarks 1.5 m apart is dense too; the loop and the clusters world keep both. The count
    against a closed form: a route of one straight segment there and back, landmarks on a
    line beside it."""
    for dense_config in (SimConfig(scenario="large"),
                         SimConfig(num_landmarks=600, min_separation=1.5)):
        dense = recommended_params(dense_config)
        assert dense["loop_closure_matches"] == 0 and "smoothing_period" not in dense
    for scenario in ("loop", "clusters"):
        params = recommended_params(SimConfig(scenario=scenario))
        assert params["loop_closure_matches"] == 2 and params["smoothing_period"] == 2.0
    # Route 0 -> 100 m and back, sampled every 5 m: 40 points at x = 0, 5, ..., 100, ..., 5.
    # Landmarks at x = 0, 1, ..., 100, 3 m off the route: within 5.5 m of a point at x, those
    # with |dx| <= 4 (9, fewer near the ends; 4.6 at most, away from any rounding).
    line = np.column_stack([np.arange(101.0), np.full(101, 3.0)])
    world = World(np.array([[0.0, 0.0], [100.0, 0.0]]),
                  LandmarkSet(line, np.arange(101, dtype=np.int32)))
    xs = np.concatenate([np.arange(0.0, 100.0, 5.0), np.arange(100.0, 0.0, -5.0)])
    expected = np.mean([np.count_nonzero(np.abs(line[:, 0] - x) <= 4.0) for x in xs])
    assert landmarks_in_range(world, 5.5) == pytest.approx(expected)


def test_odometry_with_turns_not_made_is_recommended_the_fault_recovery():
    assert recommended_params(SimConfig(scenario="faults"))["fault_recovery_matches"] == 3
    assert "fault_recovery_matches" not in recommended_params(SimConfig(scenario="room"))


def test_a_sensor_that_misses_without_clutter_is_recommended_its_detection_probability():
    missing = recommended_params(SimConfig(detection_probability=0.3))
    assert missing["detection_probability"] == 0.3
    assert "logodds_missed" not in missing
    FastSLAMConfig(**{k: v for k, v in missing.items() if k != "pose_estimate"
                      and not k.endswith("_rate")}).validate()
    assert "detection_probability" not in recommended_params(SimConfig())
    assert "detection_probability" not in recommended_params(SimConfig(scenario="clutter"))


def test_bad_settings_are_rejected_by_name():
    with pytest.raises(ValueError, match="speed"):
        simulate(SimConfig(speed=0.0))
    with pytest.raises(ValueError, match="scenario"):
        simulate(SimConfig(scenario="moon"))


def test_written_parameter_file_applies_under_any_namespace(tmp_path):
    from fastslam_ros.node import read_params_file
    from fastslam_ros.output import write_params_yaml
    params = recommended_params(SimConfig().resolved())
    path = write_params_yaml(tmp_path / "sim.yaml", params, "Recommended\nparameters")
    assert path.read_text().startswith("# Recommended\n# parameters\n/**:\n")
    assert read_params_file(path, "/robot1/fastslam") == pytest.approx(params)


# ---------------------------------------------------------------- the people simulator's crowd


def _distance_to_walls(points: np.ndarray) -> np.ndarray:
    """(K,) distance (m) of points (K, 2) to the nearest wall or furniture rectangle."""
    walls = np.array(crowd_model.WALLS)
    dx = np.maximum(np.maximum(walls[None, :, 0] - points[:, None, 0],
                               points[:, None, 0] - walls[None, :, 1]), 0.0)
    dy = np.maximum(np.maximum(walls[None, :, 2] - points[:, None, 1],
                               points[:, None, 1] - walls[None, :, 3]), 0.0)
    return np.hypot(dx, dy).min(axis=1)


def _walk_crowd(crowd, duration: float, robot=(9.0, 10.5, 0.0)):
    """Step ``crowd`` for ``duration`` s at 50 Hz; yield (t, ids, positions) every step."""
    dt = 0.02
    for k in range(int(round(duration / dt))):
        t = (k + 1) * dt
        crowd.step(t, dt, np.array(robot))
        yield t, [p.ident for p in crowd.people], np.array([p.position for p in crowd.people])


@pytest.mark.parametrize("seed,people", [(1, 5), (2, 5), (3, 8)])
def test_simulated_people_keep_apart_stay_off_walls_and_keep_walking(seed, people):
    crowd = crowd_model.Crowd(people, np.random.default_rng([seed, 0]))
    closest, off_walls = np.inf, np.inf
    last_change, stuck = {}, 0.0
    state = {}
    for t, _, positions in _walk_crowd(crowd, 150.0):
        if len(positions) > 1:
            gaps = np.linalg.norm(positions[:, None] - positions[None], axis=2)
            closest = min(closest, gaps[np.triu_indices(len(positions), 1)].min())
        if len(positions):
            off_walls = min(off_walls, _distance_to_walls(positions).min())
        for person in crowd.people:
            now = (person.node, len(person.path), person.pause > 0.0)
            if state.get(person.ident) != now:
                state[person.ident], last_change[person.ident] = now, t
            elif person.pause <= 0.0:
                stuck = max(stuck, t - last_change[person.ident])
    # solid bodies, from the first step on (newcomers enter only where the way is clear)
    assert closest >= crowd_model.PERSONAL_DISTANCE - 1e-9
    assert off_walls >= crowd_model.PERSON_RADIUS
    # no deadlock: the longest edge (5.4 m) takes 11 s at the slowest 0.5 m/s; passing,
    # waiting and yielding may add some seconds, never minutes
    assert stuck < 30.0
    assert crowd.next_id >= people + 4  # people keep leaving and newcomers keep entering


def _two_walkers(first: tuple, second: tuple):
    """A crowd of two people walking given (start node, path) at 0.8 m/s, no pause."""
    crowd = crowd_model.Crowd(0, np.random.default_rng(0))
    for ident, (start, path) in enumerate((first, second)):
        crowd.people.append(crowd_model.Person(
            ident, np.array(crowd_model.NODES[start], dtype=float), start,
            path=deque(path), speed=0.8))
    crowd.next_id = 2
    return crowd


@pytest.mark.parametrize("first,second,goals", [
    # face to face along the corridor: they step aside and pass
    (("c2", ["c3"]), ("c3", ["c2"]), ("c3", "c2")),
    # through one door from both sides at once: one waits or yields, both get through
    (("c1", ["door_a", "room_a"]), ("room_a", ["door_a", "c1"]), ("room_a", "c1")),
])
def test_two_people_meeting_head_on_pass_each_other(first, second, goals):
    crowd = _two_walkers(first, second)
    reached = [math.inf, math.inf]
    closest = np.inf
    for t, _, positions in _walk_crowd(crowd, 40.0, robot=(-10.0, -10.0, 0.0)):
        closest = min(closest, float(np.linalg.norm(positions[0] - positions[1])))
        for person in crowd.people:
            if person.node == goals[person.ident] and reached[person.ident] == math.inf:
                reached[person.ident] = t
    assert closest >= crowd_model.PERSONAL_DISTANCE - 1e-9
    walk = [np.linalg.norm(np.subtract(crowd_model.NODES[goals[i]], crowd_model.NODES[start]))
            for i, (start, _) in enumerate((first, second))]
    # both arrive, within the walk at 0.8 m/s plus a bounded wait
    assert max(r - w / 0.8 for r, w in zip(reached, walk)) < 12.0


def test_the_simulated_robot_stands_for_people_in_its_way_and_they_step_aside():
    # 12 people in 60 s: the robot meets people in the corridor and in doors; it stops short of
    # them (a person's centre never within 0.5 m of the robot's), they make way, and it drives
    # on (most of its 26.7 m route within the minute; driving through them, it covers all of it
    # and comes within 0.05 m of a person's centre on this seed)
    from fastslam_ros.tools.simulation.people_sim import PeopleSimConfig, simulate_people
    run = simulate_people(PeopleSimConfig(seed=10, duration=60.0, people=12))
    closest = np.inf
    for stamp, (_, positions) in zip(run.people_stamps, run.people):
        pose = run.truth.poses[np.searchsorted(run.truth.stamps, stamp)]
        if len(positions):
            closest = min(closest, np.linalg.norm(positions - pose[:2], axis=1).min())
    travelled = np.linalg.norm(np.diff(run.truth.poses[:, :2], axis=0), axis=1).sum()
    assert closest > 2.0 * crowd_model.PERSON_RADIUS + 0.1
    assert travelled > 20.0


def test_simulated_crowd_is_deterministic_by_seed():
    def track(seed):
        crowd = crowd_model.Crowd(5, np.random.default_rng([seed, 0]))
        return [positions.copy() for _, _, positions in _walk_crowd(crowd, 20.0)][-1]
    np.testing.assert_array_equal(track(4), track(4))
    assert track(4).shape != track(5).shape or not np.array_equal(track(4), track(5))


def test_room_scenario_sees_its_tubes_from_the_laser_ahead_of_the_centre():
    """The room: a 20-minute default, 17 tubes inside the room, 10 Hz readings of the tubes
    within 0.4-5.6 m and 4.2 rad of the laser 0.219 m ahead of the robot's centre, about 60 %
    of them detected, each the tube's surface facing the laser (its radius nearer)."""
    assert SimConfig(scenario="room").resolved().duration == 1200.0
    config = SimConfig(scenario="room", duration=60.0, sigma_range=1e-9, sigma_bearing=1e-9)
    bag = simulate(config)
    truth = bag.landmarks_truth.positions
    assert len(truth) == 17 and np.all((truth > 0.0) & (truth < 6.0))
    np.testing.assert_allclose(np.diff(bag.scans.stamps), 0.1, atol=1e-6)
    index_of = {round(t * 40): i for i, t in enumerate(bag.ground_truth.stamps)}
    detected = in_view = 0
    for stamp, points, ids in zip(bag.scans.stamps, bag.scans.points, bag.scans.ids):
        x, y, theta = bag.ground_truth.poses[index_of[round(stamp * 40)]]
        c, s = math.cos(theta), math.sin(theta)
        laser = np.array([x + 0.219 * c, y + 0.219 * s])
        offset = truth - laser
        distance = np.hypot(offset[:, 0], offset[:, 1])
        bearing = np.angle(np.exp(1j * (np.arctan2(offset[:, 1], offset[:, 0]) - theta)))
        visible = (distance >= 0.4) & (distance <= 5.6) & (np.abs(bearing) <= 2.1)
        ranges = np.hypot(points[:, 0], points[:, 1])
        np.testing.assert_allclose(ranges, distance[ids] - 0.1, atol=1e-4)
        np.testing.assert_allclose(np.arctan2(points[:, 1], points[:, 0]), bearing[ids],
                                   atol=1e-4)
        assert np.all(visible[ids])
        detected += len(ids)
        in_view += int(np.count_nonzero(visible))
    share = detected / in_view
    assert abs(share - 0.6) < 4.0 * math.sqrt(0.24 / in_view) + 0.01
    params = recommended_params(config)
    assert (params["sensor_x"], params["min_range"], params["detection_probability"]) == (
        0.219, 0.4, 0.6)


def test_faults_scenario_turns_and_slips_only_in_its_episodes():
    """The faults scenario (noise-free controls): every control step where the robot and its
    odometry differ is a turn not executed (the robot keeps its heading, the odometry turns)
    or a slip (the robot covers 30 % of the odometry's distance), and each kind takes about
    its share of the time (2 episodes of 1 s a minute, Poisson: about 3 %)."""
    assert SimConfig(scenario="faults").resolved().turn_faults == 2.0
    # (a value left at its default takes the room's: the noise is set tiny, not 0)
    config = SimConfig(scenario="faults", duration=600.0, sigma_speed=1e-15,
                       sigma_turn_rate=1e-15)
    bag = simulate(config)
    truth, odometry = bag.ground_truth.poses, bag.odometry.poses
    moved = relative_pose(truth[:-1], truth[1:])
    reported = relative_pose(odometry[:-1], odometry[1:])
    true_distance = np.hypot(moved[:, 0], moved[:, 1])
    odometry_distance = np.hypot(reported[:, 0], reported[:, 1])
    not_turned = (np.abs(moved[:, 2]) < 1e-12) & (np.abs(reported[:, 2]) > 1e-9)
    slipped = np.isclose(true_distance, 0.3 * odometry_distance, rtol=1e-6) & (
        odometry_distance > 1e-6)
    same = (np.abs(moved[:, 2] - reported[:, 2]) < 1e-9) & np.isclose(
        true_distance, odometry_distance, rtol=1e-6, atol=1e-9)
    assert np.all(same | not_turned | slipped)
    steps = len(moved)
    for share in (np.count_nonzero(~same & ~slipped), np.count_nonzero(slipped)):
        assert 0.01 * steps < share < 0.06 * steps
    clean = simulate(dataclasses.replace(config, scenario="room"))
    np.testing.assert_allclose(clean.odometry.poses, clean.ground_truth.poses, atol=1e-6)


def test_a_faulty_vehicle_drives_the_same_route_twice_alike():
    """One vehicle driven twice on the same draws: an episode under way at the end of the
    first drive does not leak into the second."""
    from fastslam_ros.tools.simulation.world import DifferentialDrive, OdometryFaults
    vehicle = DifferentialDrive(1.0, 1.0, 0.2, 0.05, 0.1,
                                faults=OdometryFaults(60.0, 60.0, 100.0))  # long episodes
    route = np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 5.0], [0.0, 5.0]])
    first = vehicle.drive(route, 1, 40.0, np.random.default_rng(1), duration=20.0)
    second = vehicle.drive(route, 1, 40.0, np.random.default_rng(1), duration=20.0)
    np.testing.assert_array_equal(first[0], second[0])
    np.testing.assert_array_equal(first[1], second[1])
