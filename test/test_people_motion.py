# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The person motion models (people/person_motion.py) against closed forms, their parameter,
and people walking behind an occluder in the tracker."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fastslam_ros.people import OccupancyMap, PeopleTracker, TrackerSettings
from fastslam_ros.people.person_motion import INITIAL_SPEED_SIGMA, PersonMotion, cap_speed
from test_people_core import room, scan_at
from test_people_core import tracker_at as core_tracker_at

SAMPLES = 40000


def linear_moments(x0: float, v0: float, sigma_a: float, tau: float, dt: float, steps: int,
                   q: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Mean (2,) and covariance (2, 2) of one axis' (position, velocity) after ``steps`` steps
    of the linear model s' = F s + G u + [w, 0], u ~ N(0, sigma_a^2 dt), w ~ N(0, q^2 dt),
    with F = [[1, dt (1 + d) / 2], [0, d]], G = [dt / 2, 1], d = exp(-dt / tau) (Kalman's
    prediction equations)."""
    d = math.exp(-dt / tau)
    f = np.array([[1.0, 0.5 * dt * (1.0 + d)], [0.0, d]])
    g = np.array([0.5 * dt, 1.0])
    mean, cov = np.array([x0, v0]), np.zeros((2, 2))
    for _ in range(steps):
        mean = f @ mean
        cov = f @ cov @ f.T + sigma_a ** 2 * dt * np.outer(g, g) + np.diag([q * q * dt, 0.0])
    return mean, cov


def sample_moments(motion: PersonMotion, start: np.ndarray, velocity: np.ndarray, dt: float,
                   steps: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Sample means and covariances of (x, vx) and (y, vy) after ``steps`` predictions of
    SAMPLES particles."""
    rng = np.random.default_rng(seed)
    positions = np.broadcast_to(start, (SAMPLES, 2)).copy()
    velocities = np.broadcast_to(velocity, (SAMPLES, 2)).copy()
    for _ in range(steps):
        positions, velocities = motion.predict(positions, velocities, dt, rng)
    axes = [np.stack([positions[:, i], velocities[:, i]], axis=1) for i in range(2)]
    return (np.stack([a.mean(axis=0) for a in axes]), np.stack([np.cov(a.T) for a in axes]))


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("velocity, dt, steps, q", [
    ((0.0, 0.0), 0.1, 1, 0.0), ((0.0, 0.0), 0.5, 1, 0.0), ((0.8, -0.3), 0.1, 1, 0.0),
    ((0.8, -0.3), 0.4, 1, 0.0), ((0.6, 0.2), 0.1, 15, 0.0), ((0.0, 0.0), 0.1, 1, 0.2),
    ((0.8, -0.3), 0.4, 1, 0.2), ((0.6, 0.2), 0.1, 15, 0.2)])
def test_constant_velocity_prediction_matches_the_closed_form(seed, velocity, dt, steps, q):
    """Mean and covariance of (position, velocity) per axis after dt (or 15 steps of it),
    for a person at rest and one walking, with and without the Brownian step, match the
    linear Gaussian model's moments (the speed cap far away: it scales less than 1e-6 of
    the samples)."""
    sigma_a, tau = 1.0, 2.0
    motion = PersonMotion("constant_velocity", sway=q, acceleration=sigma_a,
                          velocity_time=tau, max_speed=10.0)
    start = np.array([2.0, 3.0])
    means, covs = sample_moments(motion, start, np.array(velocity), dt, steps, seed)
    for axis in range(2):
        mean, cov = linear_moments(start[axis], velocity[axis], sigma_a, tau, dt, steps, q)
        std = np.sqrt(np.diag(cov))
        # sample mean: standard error std / sqrt(n); allow 5 of them
        np.testing.assert_allclose(means[axis], mean, atol=5 * std.max() / math.sqrt(SAMPLES))
        # sample (co)variance: relative standard error about sqrt(2 / n) = 0.7 %
        np.testing.assert_allclose(np.diag(covs[axis]), np.diag(cov), rtol=0.05)
        correlation = covs[axis][0, 1] / (std[0] * std[1])
        assert correlation == pytest.approx(cov[0, 1] / (std[0] * std[1]), abs=0.03)


def test_constant_velocity_closed_form_by_hand():
    """The one-step moments written out: E[x'] = x + (1 + d) v dt / 2, Var[x'] =
    sigma_a^2 dt^3 / 4, Cov[x', v'] = sigma_a^2 dt^2 / 2, Var[v'] = sigma_a^2 dt."""
    dt, tau, sigma_a, v = 0.5, 2.0, 1.2, 0.7
    d = math.exp(-dt / tau)
    mean, cov = linear_moments(0.0, v, sigma_a, tau, dt, 1)
    np.testing.assert_allclose(mean, [(1 + d) * v * dt / 2, d * v])
    np.testing.assert_allclose(cov, sigma_a ** 2 * np.array([[dt ** 3 / 4, dt ** 2 / 2],
                                                             [dt ** 2 / 2, dt]]))


def test_constant_velocity_moves_alike_whatever_the_scan_rate():
    """One second of walking predicted in 10 steps (a 10 Hz laser) or in 40 (40 Hz): the
    spread of position and velocity agree within 10 % (white-noise acceleration; a
    per-step acceleration would spread the 10 Hz velocities twice as wide)."""
    motion = PersonMotion("constant_velocity", sway=0.1, acceleration=0.6, velocity_time=2.0,
                          max_speed=10.0)
    start, velocity = np.array([2.0, 3.0]), np.array([0.8, 0.0])
    means_10, covs_10 = sample_moments(motion, start, velocity, 0.1, 10, seed=1)
    means_40, covs_40 = sample_moments(motion, start, velocity, 0.025, 40, seed=2)
    np.testing.assert_allclose(means_10, means_40, atol=0.02)
    np.testing.assert_allclose(np.diagonal(covs_10, axis1=1, axis2=2),
                               np.diagonal(covs_40, axis1=1, axis2=2), rtol=0.1)


def test_constant_velocity_speeds_are_capped_keeping_their_direction():
    rng = np.random.default_rng(7)
    motion = PersonMotion("constant_velocity", acceleration=20.0, velocity_time=5.0,
                          max_speed=1.5)
    positions = np.zeros((5000, 2))
    velocities = rng.normal(0.0, 1.0, (5000, 2))
    _, after = motion.predict(positions, velocities, 0.5, rng)
    speed = np.hypot(after[:, 0], after[:, 1])
    assert speed.max() <= 1.5 + 1e-12
    assert np.mean(speed > 1.5 - 1e-9) > 0.9           # most hit the bound
    raw = np.array([[3.0, 4.0], [0.3, -0.4]])
    np.testing.assert_allclose(cap_speed(raw, 1.5), [[0.9, 1.2], [0.3, -0.4]])


def test_brownian_prediction_keeps_velocities_and_matches_the_closed_form():
    rng = np.random.default_rng(3)
    q, dt = 0.4, 0.25
    motion = PersonMotion("brownian", diffusion=q)
    positions = np.zeros((SAMPLES, 2))
    velocities = np.zeros((SAMPLES, 2))
    moved, after = motion.predict(positions, velocities, dt, rng)
    np.testing.assert_array_equal(after, 0.0)
    np.testing.assert_allclose(moved.var(axis=0), [q * q * dt] * 2, rtol=0.05)
    np.testing.assert_array_equal(motion.initial_velocities((4, 3, 2), rng), 0.0)


def test_new_people_start_with_spread_velocities():
    rng = np.random.default_rng(5)
    motion = PersonMotion("constant_velocity", max_speed=10.0)
    velocities = motion.initial_velocities((SAMPLES, 2), rng)
    np.testing.assert_allclose(velocities.std(axis=0), [INITIAL_SPEED_SIGMA] * 2, rtol=0.03)


def test_an_unknown_person_motion_fails_naming_the_parameter():
    with pytest.raises(ValueError, match="person_motion"):
        TrackerSettings(person_motion="kalman").validate()
    with pytest.raises(ValueError, match="person_motion"):
        PersonMotion("kalman")
    with pytest.raises(ValueError, match="person_velocity_time"):
        TrackerSettings(person_velocity_time=0.0).validate()
    with pytest.raises(ValueError, match="person_acceleration"):
        TrackerSettings(person_acceleration=-1.0).validate()


# --- in the tracker ---------------------------------------------------------------------------

def tracker_at(grid: OccupancyMap, pose, **settings) -> PeopleTracker:
    """``test_people_core``'s small tracker with 50 particles per person."""
    return core_tracker_at(grid, pose, **{"people_particles": 50, **settings})


def test_the_particles_velocities_follow_a_walking_person():
    """A person walking straight at 0.8 m/s for 3 s: the detections select the particles
    that move with it, so their mean velocity is the person's (within 0.25 m/s)."""
    grid = room()
    pose = np.array([1.0, 5.0, 0.0])
    tracker = tracker_at(grid, pose, person_motion="constant_velocity", num_particles=1,
                         people_particles=200)
    velocity = np.array([0.0, 0.8])
    for k in range(31):
        person = np.array([6.0, 3.5]) + velocity * 0.1 * k
        tracker.update(0.1 * k, scan_at(grid, pose, [person]))
    slots = np.flatnonzero(tracker.alive[0])
    assert len(slots) == 1
    estimate = tracker.velocities[0, slots[0]].mean(axis=0)
    assert np.linalg.norm(estimate - velocity) < 0.25


def occlusion_run(occluder: str, motion: str, seed: int) -> list[set[int]]:
    """A person walking straight across the view at 1 m/s, 5.9 m from the robot, wholly
    hidden for about 1.5 s behind an occluder: a 1 m wide pillar in the map 3 m from the
    robot (its shadow +-0.98 m wide at the walker's range), or a person (radius 0.2 m)
    standing still 1.3 m from the robot (+-0.91 m); the published ids near the walker, per
    reading."""
    walls = [(4.0, 4.3, 4.5, 5.5)] if occluder == "pillar" else []
    grid = room(walls)
    pose = np.array([1.0, 5.0, 0.0])
    tracker = tracker_at(grid, pose, person_motion=motion, seed=seed)
    standing = [] if occluder == "pillar" else [np.array([2.3, 5.0])]
    ids = []
    for k in range(71):                                    # y from 1.5 to 8.5 m
        walker = np.array([6.9, 1.5 + 0.1 * k])
        tracker.update(0.1 * k, scan_at(grid, pose, [walker] + standing))
        published = tracker.published_people()
        near = np.linalg.norm(published.means - walker, axis=1) < 0.5
        ids.append(set(published.keys[near].tolist()))
    return ids


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("occluder", ["pillar", "person"])
def test_a_person_walking_behind_an_occluder_keeps_its_id(occluder, seed):
    """Before and after the occlusion the walker is published under one id, and no other id
    is ever published near it, with either motion model (Brownian: the cloud left behind is
    re-identified; constant velocity: the prediction walks on with the person)."""
    for motion in ("brownian", "constant_velocity"):
        ids = occlusion_run(occluder, motion, seed)
        before, after = ids[15:25], ids[-15:]             # y 3-4 m and 7.1-8.5 m: in view
        assert all(len(s) == 1 for s in before + after), motion
        assert set().union(*before) == set().union(*after), motion
        assert len(set().union(*ids)) == 1, motion         # never another id near it


def walk_estimate_by_hand():
    """One smoothing step written out: the mean moved 0.12 m in y in 0.1 s (1.2 m/s), the
    walk was (0.4, 0) m/s, gain 1 - exp(-0.1 / 0.5)."""
    gain = 1.0 - math.exp(-0.2)
    return np.array([0.4 + gain * (0.0 - 0.4), gain * 1.2])


def test_walking_velocity_is_smoothed_from_the_detections_and_walks_on_unseen():
    motion = PersonMotion("brownian", walk_time=0.5, velocity_time=2.0, max_speed=1.5)
    walk = motion.walk_estimate(np.array([[0.4, 0.0]]), np.array([[1.0, 2.0]]),
                                np.array([[1.0, 2.12]]), np.array([0.1]))
    np.testing.assert_allclose(walk[0], walk_estimate_by_hand())
    shift, after = motion.walk_on(np.array([[1.0, 0.0], [1.0, 0.0]]),
                                  np.array([False, True]), 0.1)
    decay = math.exp(-0.05)
    np.testing.assert_allclose(after, [[1.0, 0.0], [decay, 0.0]])      # only the unseen slows
    np.testing.assert_allclose(shift, [[0.1, 0.0], [0.05 * (1.0 + decay), 0.0]])
    fast = motion.walk_estimate(np.zeros((1, 2)), np.zeros((1, 2)), np.array([[5.0, 0.0]]),
                                np.array([1.0]))
    assert np.hypot(*fast[0]) == pytest.approx(1.5)                     # max_person_speed
    off = PersonMotion("brownian", walk_time=0.0)
    assert not off.walk_estimate(walk, np.zeros((1, 2)), np.ones((1, 2)), np.ones(1)).any()


def file_behind_a_pillar(seed: int, **settings) -> list[tuple[set[int], set[int]]]:
    """Two people walking in file at 1.2 m/s, 1 m apart, straight across the view 5.9 m from
    the robot, each wholly hidden for about 1.3 s behind a 1 m wide pillar 3 m from the robot
    (its shadow +-0.98 m wide at their range; the second one enters it while the first is
    hidden); the published ids near each (within 0.5 m), per reading."""
    grid = room([(4.0, 4.3, 4.5, 5.5)])
    pose = np.array([1.0, 5.0, 0.0])
    tracker = tracker_at(grid, pose, **{"person_motion": "brownian", "seed": seed, **settings})
    ids = []
    for k in range(75):                                    # the first: y from 1.5 to 10.4 m
        first = np.array([6.9, 1.5 + 0.12 * k])
        second = first - (0.0, 1.0)
        tracker.update(0.1 * k, scan_at(grid, pose, [first, second]))
        published = tracker.published_people()
        ids.append(tuple(set(published.keys[np.linalg.norm(published.means - person, axis=1)
                                            < 0.5].tolist()) for person in (first, second)))
    return ids


@pytest.mark.parametrize("seed", range(1, 11))
def test_people_walking_in_file_behind_a_pillar_keep_their_ids(seed):
    """From their confirmation (both in view from y 3 m on) to the end, each of the two
    people is published under one id of its own and no other id is ever published near it:
    the hidden people's clouds walk on with them (person_walk_time), so neither comes out
    near the other's cloud. With Brownian clouds alone (person_walk_time 0), left behind in
    the shadow, the first person's id is published on the second one in 6 of these 10
    seeds."""
    ids = file_behind_a_pillar(seed)[15:]
    first, second = (set().union(*(step[i] for step in ids)) for i in (0, 1))
    assert len(first) == 1 and len(second) == 1 and first != second
    after = ids[-14:-6]                       # y 8.8-9.7 m: the first then enters the wall
    assert all(step[0] == first for step in ids[:5] + after)  # in view before and after
    assert all(step[1] == second for step in ids[:5] + after)
