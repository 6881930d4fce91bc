# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The people tracker's core against independent expectations: closed forms, brute force,
scripted occlusions, and the conditional structure through resampling."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fastslam_ros.core.existence import (LOGODDS_MAX, in_perceptual_range, removed,
                                         update_logodds)
from fastslam_ros.people import OccupancyMap, PeopleTracker, Scan, TrackerSettings
from fastslam_ros.core.resampling import batched_systematic_resample
from fastslam_ros.people.localization import roughen
from fastslam_ros.tools.simulation.people_sim import cast_scan

BEAMS = 360
ANGLES = -math.pi + (np.arange(BEAMS) + 0.5) * (2.0 * math.pi / BEAMS)
SMALL = dict(num_particles=20, people_particles=30, max_people=6, seed=3)


def room(walls=()) -> OccupancyMap:
    """A 10 m x 10 m room at 0.05 m with a border wall and extra wall rectangles."""
    cells = 200
    centres = (np.arange(cells) + 0.5) * 0.05
    x, y = np.meshgrid(centres, centres)
    occupied = (x < 0.15) | (x > 9.85) | (y < 0.15) | (y > 9.85)
    for x0, x1, y0, y1 in walls:
        occupied |= (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
    return OccupancyMap(occupied, ~occupied, 0.05)


def scan_at(grid: OccupancyMap, pose, people) -> Scan:
    people = np.asarray(people, dtype=float).reshape(-1, 2)
    ranges = cast_scan(grid, np.asarray(pose, dtype=float), ANGLES, people, 12.0)
    return Scan(ranges, float(ANGLES[0]), float(ANGLES[1] - ANGLES[0]), 12.0)


def tracker_at(grid: OccupancyMap, pose, **settings) -> PeopleTracker:
    tracker = PeopleTracker(TrackerSettings(**{**SMALL, **settings}), grid)
    tracker.reset(np.asarray(pose, dtype=float), np.diag([1e-6, 1e-6, 1e-8]))
    return tracker


def run(tracker: PeopleTracker, grid, pose, people, steps: int, start: float = 0.0) -> float:
    for k in range(steps):
        tracker.update(start + 0.1 * k, scan_at(grid, pose, people))
    return start + 0.1 * steps


# --- existence rule ----------------------------------------------------------------------------

def test_existence_rule_saturates_and_removes():
    logodds = np.array([0.0, LOGODDS_MAX, 0.5, -0.2])
    observed = np.array([True, True, False, False])
    missed = np.array([False, False, True, False])
    new = update_logodds(logodds, observed, missed, 1.0, -0.7)
    np.testing.assert_allclose(new, [1.0, LOGODDS_MAX, -0.2, -0.2])
    np.testing.assert_array_equal(removed(new, -0.1), [False, False, True, True])
    inside = in_perceptual_range(np.array([0.05, 1.0, 5.0, 1.0]), np.array([0.0, 0.0, 0.0, 2.0]),
                                 0.1, 4.0, field_of_view=math.pi)
    np.testing.assert_array_equal(inside, [False, True, False, False])


# --- models ------------------------------------------------------------------------------------

def test_brownian_spread_matches_closed_form():
    """After k steps of dt, a person particle has moved by N(0, q^2 k dt I)."""
    grid = room()
    q, dt, steps = 0.4, 0.1, 25
    tracker = tracker_at(grid, (5.0, 5.0, 0.0), num_particles=1, people_particles=20000,
                         person_motion="brownian", person_diffusion=q)
    tracker.alive[0, 0] = True
    tracker.people[0, 0] = (2.0, 3.0)
    tracker._diffuse_people(0.0)
    for k in range(1, steps + 1):
        tracker._diffuse_people(k * dt)
    moved = tracker.people[0, 0] - (2.0, 3.0)
    expected = q * q * steps * dt
    covariance = np.cov(moved.T)
    # 20000 samples: the variance's relative standard error is sqrt(2 / 20000) = 1 %
    np.testing.assert_allclose(np.diag(covariance), [expected, expected], rtol=0.05)
    assert abs(covariance[0, 1]) < 0.05 * expected
    np.testing.assert_allclose(moved.mean(axis=0), [0.0, 0.0], atol=5 * math.sqrt(expected / 20000))


def test_likelihood_field_matches_brute_force():
    rng = np.random.default_rng(0)
    occupied = rng.random((30, 40)) < 0.03
    occupied[5, 7] = True
    grid = OccupancyMap(occupied, ~occupied, 0.1, origin=(-1.0, 2.0), max_distance=1.5)
    rows, cols = np.nonzero(occupied)
    cell_rows, cell_cols = np.indices(occupied.shape)
    brute = np.sqrt((cell_rows[..., None] - rows) ** 2 + (cell_cols[..., None] - cols) ** 2
                    ).min(axis=-1) * 0.1
    np.testing.assert_allclose(grid.distance, np.minimum(brute, 1.5), atol=1e-12)
    centres = np.stack([-1.0 + (cell_cols + 0.5) * 0.1, 2.0 + (cell_rows + 0.5) * 0.1], axis=-1)
    np.testing.assert_allclose(grid.distance_at(centres), grid.distance)
    assert grid.distance_at(np.array([[-5.0, 0.0]]))[0] == 1.5  # off the grid


def test_batched_systematic_resample_keeps_floor_or_ceil_copies():
    rng = np.random.default_rng(1)
    weights = rng.random((50, 20)) ** 3
    weights /= weights.sum(axis=1, keepdims=True)
    index = batched_systematic_resample(weights, rng)
    counts = np.stack([np.bincount(row, minlength=20) for row in index])
    assert np.all(counts >= np.floor(20 * weights) - 1e-9)
    assert np.all(counts <= np.ceil(20 * weights) + 1e-9)


# --- tracking ----------------------------------------------------------------------------------

def test_person_entering_is_tracked_and_leaving_is_removed():
    grid = room()
    pose = (2.0, 5.0, 0.0)
    tracker = tracker_at(grid, pose)
    t = run(tracker, grid, pose, [], 5)
    assert len(tracker.people_of().keys) == 0
    t = run(tracker, grid, pose, [(6.0, 5.5)], 10, t)
    people = tracker.people_of()
    assert len(people.keys) == 1
    assert np.linalg.norm(people.means[0] - (6.0, 5.5)) < 0.15
    key = int(people.keys[0])
    t = run(tracker, grid, pose, [(6.1, 5.6)], 5, t)
    assert tracker.people_of().keys.tolist() == [key]          # the id is stable
    run(tracker, grid, pose, [], 6, t)                         # left: in view, unseen
    assert len(tracker.people_of().keys) == 0
    assert not tracker.alive.any()


def test_person_behind_a_wall_is_kept():
    """Hidden behind a wall for 3 s, a person is kept (its Brownian cloud, 0.7 m after 3 s,
    stays within lost_spread; constant_velocity's grows faster, see test_people_motion)."""
    wall = (5.0, 5.2, 3.0, 7.0)
    grid = room([wall])
    pose = (2.0, 5.0, 0.0)
    tracker = tracker_at(grid, pose, person_motion="brownian")
    # seen while the robot looks past the wall's end, then hidden behind the wall
    seen_from = (2.0, 9.2, 0.0)
    tracker.reset(np.asarray(seen_from), np.diag([1e-6, 1e-6, 1e-8]))
    t = run(tracker, grid, seen_from, [(7.0, 6.0)], 8)
    assert len(tracker.people_of().keys) == 1
    tracker.poses[:] = pose
    run(tracker, grid, pose, [(7.0, 6.0)], 30, t)
    assert len(tracker.people_of().keys) == 1


def test_person_behind_another_person_is_kept_and_one_in_the_open_is_removed():
    grid = room()
    pose = (1.0, 5.0, 0.0)
    tracker = tracker_at(grid, pose)
    t = run(tracker, grid, pose, [(3.0, 5.0), (6.0, 6.5)], 8)
    assert len(tracker.people_of().keys) == 2
    # a third person steps in front of the far one; the far one stays behind it
    far = (6.0, 6.5)
    front = (3.0, 5.0 + 1.5 * 2.0 / 5.0)
    t = run(tracker, grid, pose, [(3.0, 5.0), front, far], 3, t)
    count = len(tracker.people_of().keys)
    run(tracker, grid, pose, [front, far[:1] + (6.5,)], 30, t)   # the first person left
    people = tracker.people_of()
    assert len(people.keys) == count - 1
    # the far person's cloud stays in the front person's shadow: on the line of sight through
    # the far person (it may drift along it, as a Brownian person hidden for 3 s may have)
    offset = people.means - pose[:2]
    sight = (np.asarray(far) - pose[:2]) / np.linalg.norm(np.asarray(far) - pose[:2])
    across = np.abs(sight[0] * offset[:, 1] - sight[1] * offset[:, 0])
    along = offset @ sight - np.linalg.norm(np.asarray(far) - pose[:2])
    assert np.any((across < 0.2) & (np.abs(along) < 1.0))


@pytest.mark.parametrize("publish_hidden", [True, False])
def test_a_person_hidden_behind_another_is_published_only_with_publish_hidden(publish_hidden):
    """A person who steps behind another stays tracked (same key) either way; published
    while hidden only with publish_hidden, and published again, under its id, once seen."""
    grid = room()
    pose = (1.0, 5.0, 0.0)
    tracker = tracker_at(grid, pose, publish_hidden=publish_hidden)
    far, near = (6.0, 5.0), (3.0, 6.0)
    t = run(tracker, grid, pose, [far, near], 8)
    shown = tracker.published_people()
    assert len(shown.keys) == 2
    far_id = shown.keys[np.argmin(np.linalg.norm(shown.means - far, axis=1))]
    t = run(tracker, grid, pose, [far, (3.0, 5.0)], 5, t)        # the near one steps in front
    assert len(tracker.people_of().keys) == 2
    hidden = tracker.published_people()
    assert (far_id in hidden.keys) == publish_hidden
    assert len(hidden.keys) == (2 if publish_hidden else 1)
    run(tracker, grid, pose, [far, near], 3, t)                    # and back out of the way
    back = tracker.published_people()
    assert len(back.keys) == 2 and far_id in back.keys


def test_a_person_hidden_behind_a_walking_person_stays_in_its_shadow():
    """Negative information: a person hidden behind another person is not where the laser saw
    free space. Both walk across the view at the same bearing for 2 s (the far one 0.6 m);
    the far person's particles then lie in the near one's shadow (bearing within the near
    person's angular radius plus a beam, beyond it), but the few that just diffused out (a
    particle there weighs 0.1 before resampling: about 5 %), and its mean followed the
    shadow. A Brownian cloud left alone would have its mean where the far person was last
    seen and, 0.57 m wide after 2 s, less than half of its particles in the shadow."""
    grid = room()
    pose = np.array([1.0, 5.0, 0.0])
    tracker = tracker_at(grid, pose, people_particles=50)
    far = np.array([6.0, 5.0])
    t = run(tracker, grid, pose, [far], 8)
    near_distance, far_distance = 3.0, 5.0
    steps, rate = 20, 0.3 / far_distance                 # the far person walks 0.3 m/s
    for k in range(steps + 1):
        angle = rate * 0.1 * k
        direction = np.array([math.cos(angle), math.sin(angle)])
        people = [pose[:2] + near_distance * direction, pose[:2] + far_distance * direction]
        t = run(tracker, grid, pose, people, 1, t)
    slot = np.flatnonzero(tracker.alive[0] & tracker.confirmed[0]
                          & (np.linalg.norm(tracker.people[0].mean(axis=1) - people[0], axis=1)
                             > 1.0))
    assert len(slot) == 1                                # the far person is still tracked
    particles = tracker.people[0, slot[0]]
    offset = particles - pose[:2]
    bearing = np.arctan2(offset[:, 1], offset[:, 0]) - angle
    half_width = math.asin(0.2 / near_distance) + math.radians(1.0)
    in_shadow = (np.abs(bearing) <= half_width) & (np.linalg.norm(offset, axis=1)
                                                   > near_distance - 0.4)
    assert in_shadow.mean() >= 0.85
    mean = particles.mean(axis=0)
    across = direction[0] * (mean[1] - pose[1]) - direction[1] * (mean[0] - pose[0])
    assert abs(across) < 0.2                             # it started 0.6 m off


def test_a_person_unseen_in_the_open_keeps_its_brownian_cloud():
    """A person whose every particle lies in seen free space is left to the existence rule:
    its particles move by Brownian motion alone (each its own step, none duplicated by a
    resampling)."""
    grid = room()
    pose = (2.0, 5.0, 0.0)
    q = 0.4
    tracker = tracker_at(grid, pose, num_particles=1, people_particles=2000,
                         person_motion="brownian", person_diffusion=q)
    t = run(tracker, grid, pose, [(6.0, 5.5)], 3)
    before = tracker.people[0, 0].copy()
    run(tracker, grid, pose, [], 1, t)                   # gone in the open
    assert tracker.alive[0, 0]
    after = tracker.people[0, 0]
    assert len(np.unique(after, axis=0)) == len(after)
    moved = after - before
    np.testing.assert_allclose(moved.var(axis=0), [q * q * 0.1] * 2, rtol=0.1)


def test_people_particles_follow_their_robot_particle_through_resampling():
    grid = room([(6.0, 6.2, 2.0, 4.0)])
    true_pose = np.array([3.0, 5.0, 0.3])
    tracker = tracker_at(grid, true_pose, num_particles=4)
    tracker.poses = np.array([[7.0, 7.0, 2.0], true_pose, [8.0, 2.0, -1.0], [2.0, 2.0, 1.5]])
    tracker.alive[:, 0] = True
    for m in range(4):                       # a marked person per robot particle, out of range
        tracker.keys[m, 0] = 100 + m
        tracker.people[m, 0] = (40.0 + m, 40.0)
    before = tracker.people.copy()
    report = tracker.update(0.0, scan_at(grid, true_pose, []))
    assert report.resampled
    near = np.linalg.norm(tracker.poses[:, :2] - true_pose[:2], axis=1) < 0.1
    assert near.all()
    np.testing.assert_array_equal(tracker.keys[:, 0], 101)
    np.testing.assert_allclose(tracker.people[:, 0], np.broadcast_to(before[1, 0],
                                                                     tracker.people[:, 0].shape))


def test_a_new_person_is_published_once_confirmed():
    """Tentative after one detection (log-odds tau+ < logodds_confirm), published after two."""
    grid = room()
    pose = (2.0, 5.0, 0.0)
    tracker = tracker_at(grid, pose)
    t = run(tracker, grid, pose, [(6.0, 5.5)], 1)
    assert tracker.alive.any(axis=1).all()                 # tracked by every robot particle
    assert len(tracker.people_of().keys) == 0               # but not published
    run(tracker, grid, pose, [(6.0, 5.5)], 1, t)
    assert len(tracker.people_of().keys) == 1


def test_a_person_found_again_by_one_particle_takes_the_others_key():
    """A robot particle that lost a person and creates it anew for a detection takes the key
    the other particles associated that detection to."""
    grid = room()
    pose = np.array([2.0, 5.0, 0.0])
    tracker = tracker_at(grid, pose, num_particles=3)
    tracker.alive[:2, 0] = True
    tracker.keys[:2, 0] = 7
    tracker.logodds[:2, 0] = 2.0
    tracker.people[:2, 0] = (6.0, 5.5)
    tracker.next_key = 8
    tracker.update(0.0, scan_at(grid, pose, [(6.0, 5.5)]))
    keys = [set(tracker.keys[m][tracker.alive[m]].tolist()) for m in range(3)]
    assert keys == [{7}, {7}, {7}]


def test_ids_do_not_swap_when_people_cross():
    """Two people walking past each other 0.6 m apart (their outlines 0.2 m apart): from their
    confirmation through the crossing to the end, in every robot particle, each person keeps
    the key it had when confirmed (no swap), and every particle has the same two keys (the
    best particle changing does not change the ids)."""
    grid = room()
    pose = (1.0, 5.0, 0.0)
    tracker = tracker_at(grid, pose, num_particles=30)
    keys = None
    for k in range(40):
        a, b = (3.0 + 0.1 * k, 4.7), (7.0 - 0.1 * k, 5.3)      # side by side at k = 20
        tracker.update(0.1 * k, scan_at(grid, pose, [a, b]))
        if k == 0:
            continue                                         # tentative after one detection
        for m in range(tracker.num_particles):
            people = tracker.people_of(m)
            assert len(people.keys) == 2
            near_a = np.linalg.norm(people.means - a, axis=1)
            near_b = np.linalg.norm(people.means - b, axis=1)
            assert near_a.min() < 0.3 and near_b.min() < 0.3
            on_people = (int(people.keys[np.argmin(near_a)]), int(people.keys[np.argmin(near_b)]))
            keys = on_people if keys is None else keys
            assert on_people == keys, f"step {k}, particle {m}: ids {on_people}, were {keys}"


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_ids_do_not_swap_when_people_walk_side_by_side(seed):
    """Two people walking side by side 0.6 m apart at 1 m/s (their outlines 0.2 m apart),
    diagonally past the robot, the second behind the first at the start: once tracked, each
    keeps one key in every robot particle, and at the end every particle tracks both.
    Associating in scan order, a detection could take the neighbour that the next
    detection fits far better, and the two swapped."""
    grid = room()
    pose = (1.0, 5.0, 0.0)
    tracker = tracker_at(grid, pose, num_particles=30, seed=seed)
    keys = None
    apart = 0.6 * np.array([1.0, -1.0]) / math.sqrt(2.0)          # abreast of the heading
    for k in range(45):
        a = np.array([3.0, 2.0]) + 0.07 * k                        # 0.99 m/s, heading 45 deg
        b = a + apart
        tracker.update(0.1 * k, scan_at(grid, pose, [a, b]))
        for m in range(tracker.num_particles):
            people = tracker.people_of(m)
            if len(people.keys) < 2:
                assert k < 30, f"step {k}, particle {m}: {len(people.keys)} people"
                continue
            assert len(people.keys) == 2
            near_a = np.linalg.norm(people.means - a, axis=1)
            near_b = np.linalg.norm(people.means - b, axis=1)
            on_people = (int(people.keys[np.argmin(near_a)]), int(people.keys[np.argmin(near_b)]))
            keys = on_people if keys is None else keys
            assert on_people == keys, f"step {k}, particle {m}: ids {on_people}, were {keys}"


def test_a_person_hidden_for_a_while_keeps_its_id_and_one_lost_is_removed():
    """Behind a wall the person's Brownian cloud spreads as q sqrt(t): back in view after 2 s
    (spread about 0.6 m < lost_spread) it keeps its id; hidden for 20 s, far beyond
    (lost_spread / q)^2 = 6.25 s (later than that, as the wall's shadow confines the cloud),
    it is removed."""
    wall = (5.0, 5.2, 3.0, 7.0)
    grid = room([wall])
    pose = np.array([2.0, 9.2, 0.0])
    tracker = tracker_at(grid, pose, person_motion="brownian", person_diffusion=0.4,
                         lost_spread=1.0)
    t = run(tracker, grid, pose, [(7.0, 6.0)], 8)
    key = tracker.people_of().keys.tolist()
    assert len(key) == 1
    behind = np.array([2.0, 5.0, 0.0])                     # the wall hides the person
    tracker.poses[:] = behind
    t = run(tracker, grid, behind, [(7.0, 6.0)], 20, t)
    tracker.poses[:] = pose
    t = run(tracker, grid, pose, [(7.2, 6.1)], 3, t)
    assert tracker.people_of().keys.tolist() == key
    tracker.poses[:] = behind
    t = run(tracker, grid, behind, [(7.0, 6.0)], 50, t)   # 5 s: still tracked, unseen
    assert tracker.alive.any()
    run(tracker, grid, behind, [(7.0, 6.0)], 150, t)      # 20 s: lost
    assert not tracker.alive.any()


def test_seeded_runs_are_identical():
    grid = room()
    pose = (2.0, 5.0, 0.0)
    results = []
    for _ in range(2):
        tracker = tracker_at(grid, pose)
        run(tracker, grid, pose, [(6.0, 5.5)], 5)
        results.append((tracker.poses.copy(), tracker.people.copy()))
    np.testing.assert_array_equal(results[0][0], results[1][0])
    np.testing.assert_array_equal(results[0][1], results[1][1])


def test_global_localization_converges_in_an_asymmetric_room():
    grid = room([(6.0, 6.2, 2.0, 5.0), (1.0, 3.0, 7.5, 8.0)])
    pose = np.array([3.5, 4.0, 0.5])
    tracker = PeopleTracker(TrackerSettings(**{**SMALL, "global_particles": 8000}), grid)
    assert tracker.globally_localizing
    for k in range(40):
        tracker.predict(np.zeros(3), np.zeros(3))     # standing still: the noise floor only
        tracker.update(0.1 * k, scan_at(grid, pose, []))
        if not tracker.globally_localizing:
            break
    assert not tracker.globally_localizing
    mean, _ = tracker.mean_pose_and_covariance()
    assert np.linalg.norm(mean[:2] - pose[:2]) < TrackerSettings().converged_spread
    assert abs(mean[2] - pose[2]) < 0.1


def test_roughening_spread_matches_gordons_rule():
    rng = np.random.default_rng(4)
    count = 8000
    poses = np.column_stack([rng.uniform(0.0, 4.0, count), rng.uniform(1.0, 3.0, count),
                             math.pi + rng.uniform(-0.2, 0.2, count)])   # headings across +-pi
    extent = np.array([np.ptp(poses[:, 0]), np.ptp(poses[:, 1]),
                       np.ptp(poses[:, 2])])                           # before wrapping
    poses[:, 2] = np.arctan2(np.sin(poses[:, 2]), np.cos(poses[:, 2]))
    moved = roughen(poses, 0.2, rng)
    step = moved - poses
    step[:, 2] = np.arctan2(np.sin(step[:, 2]), np.cos(step[:, 2]))
    np.testing.assert_allclose(step.std(axis=0), 0.2 * extent * count ** (-1.0 / 3.0),
                               rtol=0.05)
    assert np.all(np.abs(moved[:, 2]) <= math.pi)


def test_global_localization_refines_sparse_candidates():
    """Copies of a first-reading candidate near the true pose spread (roughening) and the
    next readings find the true pose: it ends within sigma_hit of it, driving straight, where
    the odometry's noise does not move the particles sideways."""
    grid = room([(6.0, 6.2, 2.0, 5.0), (1.0, 3.0, 7.5, 8.0)])
    for seed in range(1, 6):
        settings = TrackerSettings(**{**SMALL, "global_particles": 3000, "seed": seed})
        tracker = PeopleTracker(settings, grid)
        pose = np.array([2.0, 4.0, 0.0])
        for k in range(60):
            if k:
                tracker.predict(np.array([0.05 * (k - 1), 0.0, 0.0]),
                                np.array([0.05 * k, 0.0, 0.0]))
                pose = pose + [0.05, 0.0, 0.0]
            tracker.update(0.1 * k, scan_at(grid, pose, []))
            if not tracker.globally_localizing:
                break
        assert not tracker.globally_localizing
        mean, _ = tracker.mean_pose_and_covariance()
        assert np.linalg.norm(mean[:2] - pose[:2]) < settings.sigma_hit, seed
        assert abs(mean[2] - pose[2]) < 0.02, seed


def test_settings_name_the_bad_field():
    with pytest.raises(ValueError, match="people_particles"):
        TrackerSettings(people_particles=0).validate()
    with pytest.raises(ValueError, match="logodds_remove"):
        TrackerSettings(logodds_remove=5.0).validate()
    with pytest.raises(ValueError, match="logodds_confirm"):
        TrackerSettings(logodds_confirm=-2.0).validate()
    with pytest.raises(ValueError, match="logodds_confirm"):
        TrackerSettings(logodds_confirm=3.5).validate()  # never reached: nobody published
    with pytest.raises(ValueError, match="lost_spread"):
        TrackerSettings(lost_spread=0.0).validate()


def test_a_detection_next_to_a_person_it_does_not_fit_starts_no_new_person():
    """A tight person 0.4 m from a detection (beyond p0 under N(z; mean, cov + R), inside
    DUPLICATE_GATE) is not joined by a second person; 1 m away a new person starts."""
    grid = room()
    pose = np.array([2.0, 5.0, 0.0])
    for offset, people_after in ((0.4, 1), (1.0, 2)):
        tracker = tracker_at(grid, pose, num_particles=4)
        tracker.alive[:, 0] = True
        tracker.confirmed[:, 0] = True
        tracker.logodds[:, 0] = 2.0
        tracker.keys[:, 0] = 0
        tracker.people[:, 0] = (6.0 + offset, 5.5)     # behind the real person: occluded
        tracker.next_key = 1
        report = tracker.update(0.0, scan_at(grid, pose, [(6.0, 5.5)]))
        # No person is created at all (not one created and then removed as a duplicate).
        assert report.created == people_after - 1
        np.testing.assert_array_equal(tracker.alive.sum(axis=1), people_after)


def test_a_tentative_person_on_a_confirmed_one_is_removed():
    """A tentative person 0.3 m behind a confirmed one (occluded, so no negative evidence) is
    a duplicate and removed; a tentative person 3 m away is kept."""
    grid = room()
    pose = np.array([2.0, 5.0, 0.0])
    tracker = tracker_at(grid, pose, num_particles=4)
    for slot, position, logodds in ((0, (6.0, 5.5), 2.0), (1, (6.3, 5.5), 1.0),
                                    (2, (6.0, 8.5), 1.0)):
        tracker.alive[:, slot] = True
        tracker.confirmed[:, slot] = slot == 0
        tracker.logodds[:, slot] = logodds
        tracker.keys[:, slot] = slot
        tracker.people[:, slot] = position
    tracker.next_key = 3
    tracker.update(0.0, scan_at(grid, pose, [(6.0, 5.5)]))
    np.testing.assert_array_equal(tracker.alive[:, :3], np.tile([True, False, True], (4, 1)))


def test_free_person_slots_are_never_read():
    """The per-scan summaries and spreads cover the live people only: free slots filled with
    huge values (which would overflow when squared) change nothing, and raise nothing."""
    grid = room()
    pose = (2.0, 5.0, 0.0)
    clean, dirty = tracker_at(grid, pose), tracker_at(grid, pose)
    walk = [[(6.0, 5.5), (4.0, 3.0)]] * 6 + [[(6.1, 5.6)]] * 6 + [[]] * 4
    with np.errstate(all="raise"):
        for k, people in enumerate(walk):
            dirty.people[~dirty.alive] = 1e300
            scan = scan_at(grid, pose, people)
            clean.update(0.1 * k, scan)
            dirty.update(0.1 * k, scan)
            np.testing.assert_array_equal(dirty.alive, clean.alive)
            np.testing.assert_array_equal(dirty.keys, clean.keys)
            np.testing.assert_array_equal(dirty.people[dirty.alive], clean.people[clean.alive])
            np.testing.assert_array_equal(dirty.log_weights, clean.log_weights)


def test_a_removed_person_leaves_its_slot_unconfirmed():
    """Removal frees the slot entirely: no dead slot stays confirmed."""
    grid = room()
    pose = (2.0, 5.0, 0.0)
    tracker = tracker_at(grid, pose)
    t = run(tracker, grid, pose, [(6.0, 5.5)], 5)
    assert (tracker.alive & tracker.confirmed).any(axis=1).all()
    run(tracker, grid, pose, [], 6, t)                         # left: in view, unseen
    assert not tracker.alive.any()
    assert not tracker.confirmed.any()


def see_then_hide(**settings) -> tuple[PeopleTracker, OccupancyMap, np.ndarray, float]:
    """A person at (7, 6) seen from (2, 9.2), past the end of a wall, then hidden behind the
    wall from (2, 5), where the robot stays. Brownian motion unless ``settings`` say
    otherwise (the tests using it count on its cloud's spread)."""
    grid = room([(5.0, 5.2, 3.0, 7.0)])
    seen_from = np.array([2.0, 9.2, 0.0])
    tracker = tracker_at(grid, seen_from, **{"person_motion": "brownian", **settings})
    t = run(tracker, grid, seen_from, [(7.0, 6.0)], 8)
    assert len(tracker.people_of().keys) == 1
    pose = np.array([2.0, 5.0, 0.0])
    tracker.poses[:] = pose
    return tracker, grid, pose, t


def test_a_person_back_in_view_elsewhere_keeps_its_id():
    """Hidden behind a wall for 3 s, a person comes out 4.6 m from where it was last seen
    (within max_person_speed x 3 s + 0.5 m): it is re-identified, keeps its id, and its old
    track behind the wall is gone (not a second track)."""
    tracker, grid, pose, t = see_then_hide()
    key = tracker.people_of().keys.tolist()
    t = run(tracker, grid, pose, [(7.0, 6.0)], 30, t)         # behind the wall
    assert tracker.people_of().keys.tolist() == key           # kept, unseen
    t = run(tracker, grid, pose, [(6.0, 1.5)], 3, t)          # out below the wall's end
    people = tracker.people_of()
    assert people.keys.tolist() == key
    assert np.linalg.norm(people.means[0] - (6.0, 1.5)) < 0.3
    for m in range(tracker.num_particles):
        assert tracker.keys[m][tracker.alive[m]].tolist() == key


def test_a_hidden_person_is_found_again_when_no_slot_is_free():
    """With every slot taken (max_people 1, by the hidden person itself) the person coming out
    from behind the wall is still re-identified: its track moves to the detection, counted as
    associated, not created and not unexplained."""
    tracker, grid, pose, t = see_then_hide(max_people=1)
    key = tracker.people_of().keys.tolist()
    t = run(tracker, grid, pose, [(7.0, 6.0)], 30, t)         # behind the wall
    assert tracker.alive.all()                                # no free slot in any particle
    report = tracker.update(t, scan_at(grid, pose, [(6.0, 1.5)]))
    assert (report.created, report.unexplained) == (0, 0)
    assert report.associated >= 1
    run(tracker, grid, pose, [(6.0, 1.5)], 3, t + 0.1)
    people = tracker.people_of()
    assert people.keys.tolist() == key
    assert np.linalg.norm(people.means[0] - (6.0, 1.5)) < 0.3


def test_a_lost_person_back_within_reach_keeps_its_id_and_a_newcomer_gets_a_new_one():
    """Removed as lost after 20 s behind a wall, a person coming out within reach of where it
    was last seen (0.3 m/s x 20 s + 0.5 m) takes its id back; a person appearing where no one
    could have walked in that time gets a new id."""
    tracker, grid, pose, t = see_then_hide(max_person_speed=0.3)
    key = tracker.people_of().keys.tolist()
    t = run(tracker, grid, pose, [(7.0, 6.0)], 200, t)        # 20 s hidden: lost
    assert not tracker.alive.any()
    t = run(tracker, grid, pose, [(6.0, 1.5)], 3, t)          # 4.6 m in 20 s: within reach
    assert tracker.people_of().keys.tolist() == key
    run(tracker, grid, pose, [(6.0, 1.5), (1.0, 1.0)], 3, t)  # 7.8 m away: out of reach
    keys = tracker.people_of().keys.tolist()
    assert len(keys) == 2 and key[0] in keys



def test_ids_are_voted_across_robot_particles():
    """A robot particle that gave a person another id than most of the weight takes the
    majority's id; a person of its own elsewhere keeps its id."""
    grid = room()
    pose = np.array([2.0, 5.0, 0.0])
    tracker = tracker_at(grid, pose, num_particles=3, resample_threshold=0.0)
    tracker.alive[:, 0] = tracker.confirmed[:, 0] = True
    tracker.keys[:, 0] = (5, 5, 9)
    tracker.logodds[:, 0] = 3.0
    tracker.people[:, 0] = (6.0, 5.5)
    tracker.alive[2, 1] = tracker.confirmed[2, 1] = True       # missed once: still there
    tracker.keys[2, 1] = 11
    tracker.logodds[2, 1] = 3.0
    tracker.people[2, 1] = (1.0, 5.0)
    tracker.next_key = 12
    tracker.update(0.0, scan_at(grid, pose, [(6.0, 5.5)]))
    for m in range(3):
        people = tracker.people_of(m)
        near = np.linalg.norm(people.means - (6.0, 5.5), axis=1) < 0.3
        assert people.keys[near].tolist() == [5]
    assert 11 in tracker.people_of(2).keys.tolist()


def one_published_person():
    """A tracker that has published one person at (6, 5) for 5 scans from (2, 5): (grid,
    pose, tracker, time, published ids)."""
    grid = room()
    pose = np.array([2.0, 5.0, 0.0])
    tracker = tracker_at(grid, pose)
    t = run(tracker, grid, pose, [(6.0, 5.0)], 5)
    published = tracker.published_people().keys.tolist()
    assert len(published) == 1
    return grid, pose, tracker, t, published


def test_a_published_person_keeps_its_id_when_its_key_changes():
    """Fault injection: every robot particle's key of a tracked person is replaced (as when a
    particle with another key becomes the best). Published without a break, the person keeps
    its published id; a person walking in elsewhere gets an id of its own."""
    grid, pose, tracker, t, published = one_published_person()
    tracker.keys[tracker.alive] = tracker.next_key
    tracker.next_key += 1
    t = run(tracker, grid, pose, [(6.0, 5.0)], 3, t)
    assert tracker.people_of().keys.tolist() != published      # the key changed
    assert tracker.published_people().keys.tolist() == published
    run(tracker, grid, pose, [(6.0, 5.0), (6.0, 8.0)], 5, t)
    people = tracker.published_people()
    assert len(people.keys) == 2 and len(set(people.keys.tolist())) == 2
    assert people.keys[np.argmin(np.linalg.norm(people.means - (6.0, 5.0), axis=1))] \
        == published[0]


def test_an_id_is_not_published_where_its_person_could_not_have_walked():
    """Fault injection: the key of a person published at (6, 5) turns up, in every robot
    particle, on a track 3 m away (as another robot particle's person under the same key,
    once that particle becomes the best) while no one is published near (6, 5). A person
    walks at most max_person_speed: that track is published under a fresh id."""
    grid, pose, tracker, t, published = one_published_person()
    tracker.people[tracker.alive] += (0.0, 3.0)
    run(tracker, grid, pose, [(6.0, 8.0)], 1, t)
    assert tracker.people_of().keys.tolist() == published        # the same key
    (moved,) = tracker.published_people().keys.tolist()
    assert moved != published[0]


def test_two_tracks_on_one_person_are_published_as_one_that_keeps_its_id():
    """Fault injection: a second confirmed track 0.3 m from a published person (within
    DUPLICATE_GATE) in every robot particle. One person is published, under the id published
    first; when that track is then removed, the other one carries on under the same id."""
    grid, pose, tracker, t, published = one_published_person()
    first = np.argmax(tracker.alive[0])
    slot = first + 1
    tracker.alive[:, slot] = tracker.confirmed[:, slot] = True
    tracker.logodds[:, slot] = 3.0
    tracker.keys[:, slot] = tracker.next_key
    tracker.next_key += 1
    tracker.people[:, slot] = tracker.people[:, first] + (0.0, 0.3)
    tracker.last_seen[:, slot] = t
    t = run(tracker, grid, pose, [(6.0, 5.0)], 1, t)
    assert len(tracker.people_of().keys) == 2                   # two tracks
    assert tracker.published_people().keys.tolist() == published
    tracker.alive[:, first] = False
    tracker.keys[:, first] = -1
    tracker.confirmed[:, first] = False
    t = run(tracker, grid, pose, [(6.0, 5.0)], 1, t)
    assert len(tracker.people_of().keys) == 1
    assert tracker.published_people().keys.tolist() == published


def test_of_two_tracks_on_one_person_the_continuing_one_is_published():
    """Fault injection: the key of a person published before (and now removed elsewhere)
    turns up on a second track 0.3 m from a continuously published person. The continuing
    track is published under its id; the older id on the new track is not."""
    grid = room()
    pose = np.array([2.0, 5.0, 0.0])
    tracker = tracker_at(grid, pose)
    t = run(tracker, grid, pose, [(6.0, 7.5)], 5)
    (older,) = tracker.published_people().keys.tolist()
    t = run(tracker, grid, pose, [(6.0, 7.5), (6.0, 5.0)], 5, t)
    people = tracker.published_people()
    (continuing,) = people.keys[people.keys != older].tolist()
    other = np.flatnonzero(tracker.alive[0] & (tracker.keys[0] != older))[0]
    moved = np.flatnonzero(tracker.keys[0] == older)[0]
    tracker.people[:, moved] = tracker.people[:, other] + (0.0, 0.3)   # the older key's track
    t = run(tracker, grid, pose, [(6.0, 5.0)], 1, t)
    assert older in tracker.people_of().keys.tolist()             # tracked, 0.3 m off
    assert tracker.published_people().keys.tolist() == [continuing]


def test_a_person_unseen_long_enough_to_be_uncertain_is_tracked_but_not_published():
    """Hidden behind a wall, a person's Brownian cloud grows: published (publish_hidden) while
    its position standard deviation is below publish_spread, kept (not published) beyond it,
    and published again once seen."""
    tracker, grid, pose, t = see_then_hide(publish_spread=0.5, lost_spread=1.0,
                                           publish_hidden=True)
    key = tracker.published_people().keys.tolist()
    assert key == tracker.people_of().keys.tolist()
    t = run(tracker, grid, pose, [(7.0, 6.0)], 5, t)          # 0.5 s hidden: sd about 0.3 m
    assert tracker.published_people().keys.tolist() == key
    t = run(tracker, grid, pose, [(7.0, 6.0)], 25, t)         # 3 s hidden: sd about 0.7 m
    assert tracker.people_of().keys.tolist() == key           # tracked
    assert tracker.published_people().keys.tolist() == []     # not published
    run(tracker, grid, pose, [(6.0, 1.5)], 3, t)              # back in view
    assert tracker.published_people().keys.tolist() == key


def test_the_published_id_tables_forget_people_no_robot_particle_can_bring_back():
    """A whole shift of people coming and going: the key -> id and first-published tables
    hold only people some robot particle tracks or may re-identify."""
    grid, pose, tracker, t, published = one_published_person()
    assert list(tracker._id_of_key.values()) == published
    tracker.alive[:] = False                                    # gone everywhere, unrecoverable
    tracker.keys[:] = -1
    tracker.lost_keys[:] = -1
    run(tracker, grid, pose, [], 1, t)
    assert tracker._id_of_key == {} and tracker._first_published == {}


def test_simulated_people_stamps_are_dated_like_a_recording():
    from fastslam_ros.tools.simulation.people_sim import PeopleSimConfig, simulate_people
    config = PeopleSimConfig(duration=1.0, people=1)
    run = simulate_people(config)
    assert run.odometry.stamps[0] == config.start_time == 1_700_000_000.0
    assert run.scan_stamps[0] == config.start_time
    np.testing.assert_allclose(np.diff(run.odometry.stamps), 1 / config.odometry_rate, atol=1e-6)
    np.testing.assert_allclose(np.diff(run.scan_stamps), 1 / config.scan_rate, atol=1e-6)


def test_global_localization_weighs_a_bounded_number_of_beams_whatever_the_scan(monkeypatch):
    """A dense laser (4,000 beams) costs the global localization what a 360-beam one does:
    every weighing of the robot particles uses at most GLOBAL_MAX_BEAMS beams, spread over the
    whole scan (the first and last kept beams near the scan's ends)."""
    from fastslam_ros.people import global_localization
    widths, spans = [], []
    weigh = global_localization.likelihood_field_log_weights

    def counted(distances, *args):
        widths.append(distances.shape[1])
        return weigh(distances, *args)
    monkeypatch.setattr(global_localization, "likelihood_field_log_weights", counted)
    original_ends = global_localization.beam_endpoints

    def ends(sensors, ranges, angles):
        spans.append(float(angles.max() - angles.min()))
        return original_ends(sensors, ranges, angles)
    monkeypatch.setattr(global_localization, "beam_endpoints", ends)
    room = np.zeros((200, 200), bool)
    room[[0, -1]] = room[:, [0, -1]] = True
    grid = OccupancyMap(room, ~room, 0.05, (0.0, 0.0), 1.0)
    for beams in (360, 4000):
        widths.clear()
        spans.clear()
        angles = -math.pi + (np.arange(beams) + 0.5) * 2 * math.pi / beams
        ranges = cast_scan(grid, np.array([2.0, 5.0, 0.0]), angles, np.zeros((0, 2)), 12.0)
        tracker = PeopleTracker(TrackerSettings(seed=1, global_particles=500), grid)
        tracker.update(0.0, Scan(ranges, angles[0], angles[1] - angles[0], 12.0))
        assert tracker.globally_localizing
        assert widths and max(widths) == global_localization.GLOBAL_MAX_BEAMS
        assert min(spans) > 1.9 * math.pi


def test_a_person_too_far_to_return_enough_beams_gives_no_miss():
    """Not detecting a person in view is evidence only within the range at which it returns
    ``min_detection_beams`` beams: two legs of ``leg_radius`` 0.06 m across 1-degree beams,
    0.24 / (2 x 2 pi / 360) = 6.88 m. A person 0.4 m closer loses existence when not seen;
    one 0.4 m farther keeps it."""
    grid = room()
    pose = np.array([0.5, 5.0, 0.0])
    reach = 4.0 * 0.06 / (2 * 2.0 * math.pi / BEAMS)
    for distance, missed in ((reach - 0.4, True), (reach + 0.4, False)):
        tracker = tracker_at(grid, pose, leg_radius=0.06, min_detection_beams=2)
        tracker.alive[:, 0] = tracker.confirmed[:, 0] = True
        tracker.keys[:, 0] = 7
        tracker.people[:, 0] = (0.5 + distance, 5.0)
        tracker.logodds[:, 0] = 2.0
        tracker.update(0.0, scan_at(grid, pose, []))
        assert np.all(tracker.logodds[:, 0] < 2.0) == missed
        assert np.all(tracker.logodds[:, 0] == 2.0) == (not missed)


def test_beams_of_a_partial_scan_either_way_round():
    """A 270-degree scan (541 beams, either sign of ``angle_increment``): a bearing's beam is
    the one at that angle (closed form: (bearing - angle_min) / angle_increment), also past
    +pi/4 where the difference to ``angle_min`` wraps; a bearing behind the laser is outside
    its span and takes the nearer end beam."""
    span, count = 1.5 * math.pi, 541
    bearings = np.array([1.5, -1.5, 0.0, 2.3, 3.0, -3.0, 2.4, -2.4])
    inside = np.array([True, True, True, True, False, False, False, False])
    for angle_min, increment in ((-span / 2, span / (count - 1)), (span / 2, -span / (count - 1))):
        scan = Scan(np.full(count, 5.0), angle_min, increment, 30.0)
        index = scan.beam_index(bearings)
        np.testing.assert_allclose(scan.angles[index[inside]], bearings[inside],
                                   atol=0.5 * span / (count - 1))
        np.testing.assert_array_equal(scan.covers(bearings), inside)
        ends = scan.angles[index[~inside]]
        np.testing.assert_allclose(np.abs(ends), span / 2)
        np.testing.assert_array_equal(np.sign(ends), np.sign(bearings[~inside]))


def test_a_partial_scan_gives_miss_evidence_only_within_its_span():
    """A 270-degree laser, heading +y: a person 3 m to its left (bearing 1.5 rad) in the
    open and not detected loses existence; a person 3 m behind it (outside the span) keeps
    it and is not reported. Both took the first beam's range before: the left one, with the
    wall 1.2 m down that beam, kept its existence; the one behind, with 6.9 m of free space,
    lost it."""
    grid = room()
    angles = np.radians(np.arange(-135.0, 135.5, 1.0))
    for pose, person, missed in (((5.0, 1.0, math.pi / 2), (2.0, 1.2), True),
                                 ((5.0, 5.0, math.pi / 2), (5.0, 2.0), False)):
        pose = np.array(pose)
        tracker = tracker_at(grid, pose)
        tracker.alive[:, 0] = tracker.confirmed[:, 0] = True
        tracker.keys[:, 0] = 7
        tracker.people[:, 0] = person
        tracker.logodds[:, 0] = 2.0
        ranges = cast_scan(grid, pose, angles, np.zeros((0, 2)), 12.0)
        tracker.update(0.0, Scan(ranges, float(angles[0]), float(angles[1] - angles[0]), 12.0))
        assert np.all(tracker.logodds[:, 0] < 2.0) == missed
        assert np.all(tracker.logodds[:, 0] == 2.0) == (not missed)
        # Kept, but reported only within the span: nothing observes the one behind.
        assert len(tracker.published_people().keys) == (1 if missed else 0)
