# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The real-laser world of the people simulator (two legs per person, furniture on thin legs)
against closed forms and the world's own rules, and the benchmark count of the scorer."""
from __future__ import annotations

import math
from functools import partial

import numpy as np
import pytest

from fastslam_ros.people import OccupancyMap, PeopleTracker, TrackerSettings
from fastslam_ros.people.detection import (MIXED_PIXEL_EDGES, LegModel, MixedPixelMonitor, Scan,
                                           beams_needed, deskewed, detect_legs, dynamic_beams,
                                           mixed_pixels, segment_scan, static_edges,
                                           without_mixed_pixels)
from fastslam_ros.tools.simulation import people_legs
from fastslam_ros.tools.evaluation import people_eval
from fastslam_ros.tools.evaluation.people_eval import Frame, clear_mot
from fastslam_ros.tools.simulation.crowd import build_map
from fastslam_ros.tools.simulation.people_sim import (PeopleSimConfig, cast_scan,
                                                     laser_scan_message, mix_edges,
                                                     simulate_people, sweep_poses)


def test_circle_ranges_match_the_closed_form():
    sensor = np.array([1.0, 2.0, 0.0])
    centre = np.array([[4.0, 2.0]])
    # straight at it: the near face; at bearing b: d cos b - sqrt(r^2 - d^2 sin^2 b)
    bearings = np.array([0.0, 0.01, 0.025, -0.03])
    d, r = 3.0, 0.1
    expected = d * np.cos(bearings) - np.sqrt(r ** 2 - (d * np.sin(bearings)) ** 2)
    np.testing.assert_allclose(people_legs.circle_ranges(sensor, bearings, centre, r), expected,
                               atol=1e-12)
    # beside it, behind the sensor, or no circle: nothing
    misses = people_legs.circle_ranges(sensor, np.array([0.04, math.pi]), centre, r)
    assert np.all(np.isinf(misses))
    assert np.all(np.isinf(people_legs.circle_ranges(sensor, bearings, np.zeros((0, 2)), r)))


def test_legs_are_hip_width_apart_standing_and_swing_in_antiphase_walking():
    gait = people_legs.Gait()
    position = np.array([[2.0, 3.0]])
    legs = gait.legs([7], position, np.zeros((1, 2)), 0.1)
    assert np.linalg.norm(legs[0] - legs[1]) == pytest.approx(people_legs.HIP_WIDTH)
    np.testing.assert_allclose(legs.mean(axis=0), position[0])
    gaps, along = [], []
    for _ in range(50):   # walking along +x at 1 m/s
        legs = gait.legs([7], position, np.array([[1.0, 0.0]]), 0.1)
        np.testing.assert_allclose(legs.mean(axis=0), position[0], atol=1e-12)
        gaps.append(np.linalg.norm(legs[0] - legs[1]))
        along.append(legs[0, 0] - legs[1, 0])
    widest = math.hypot(people_legs.HIP_WIDTH, 2.0 * people_legs.SWING)
    assert min(gaps) >= people_legs.HIP_WIDTH - 1e-12 and max(gaps) <= widest + 1e-12
    assert max(gaps) > 0.95 * widest          # a full stride is reached
    assert min(along) < -0.25 and max(along) > 0.25   # each leg leads in turn
    # the across offset is perpendicular to the heading (+y for walking along +x)
    np.testing.assert_allclose(abs(legs[0, 1] - legs[1, 1]), people_legs.HIP_WIDTH, atol=1e-12)


def test_leg_world_maps_every_furniture_leg_and_keeps_people_out_of_footprints():
    world = people_legs.LegWorld(build_map())
    assert world.map.is_occupied(world.furniture).all()
    assert len(world.furniture) == 4 * len(people_legs.furniture_footprints())
    for x0, x1, y0, y1 in people_legs.furniture_footprints():
        inside = np.array([[0.5 * (x0 + x1), 0.5 * (y0 + y1)]])
        assert world.map.is_free(inside).all()       # the tabletop is above the laser
        rows, cols, _ = world.map.cells(inside)
        assert not world.walkable[rows, cols].any()  # but no one stands in it


def test_a_person_broadside_returns_two_leg_arcs():
    world = people_legs.LegWorld(build_map())
    sensor = np.array([5.0, 10.0, 0.0])
    angles = np.radians(np.arange(-30.0, 30.0, 0.25))
    # a person 2 m ahead walking across the beams (+y), standing: legs at y +-0.1
    ranges, legs = world.cast(sensor, angles, [0], np.array([[7.0, 10.0]]), np.zeros((1, 2)),
                              0.1, 12.0)
    near = ranges < 3.0
    runs = np.flatnonzero(np.diff(near.astype(int)) == 1)
    assert len(runs) == 2                              # two separate arcs
    assert np.all(ranges[near] >= 2.0 - people_legs.LEG_RADIUS - 1e-9)
    assert np.all(ranges[near] <= 2.0 + 1e-9)
    np.testing.assert_allclose(np.sort(legs[:, 0]), [7.0, 7.0])


def test_legs_world_people_walk_close_to_walls_and_never_into_furniture():
    config = PeopleSimConfig(seed=2, duration=40.0, people=5, legs=True)
    run = simulate_people(config)
    world = people_legs.LegWorld(build_map())
    positions = np.concatenate([p for _, p in run.people])
    rows, cols, inside = world.map.cells(positions)
    assert inside.all() and world.walkable[rows, cols].all()
    # closer than the 0.3 m of the plain world's clearance to an obstacle, at times
    assert (world.map.distance_at(positions) < 0.45).mean() > 0.02
    # the map handed over holds the furniture legs
    assert run.grid.is_occupied(world.furniture).all()


@pytest.mark.parametrize("legs", [True, False])
def test_simulated_people_walk_on_steady_headings(legs):
    """Between two scans a walking person rarely turns back: of the 0.1 s steps of people
    walking (over 0.2 m/s) in both, under 1 % reverse (velocities at more than 90 degrees),
    as people round corners and aim through doors (in the legs world a person aiming at a
    point beside a door, in the wall, stepped to and fro against it: 10 % of the steps on
    seed 1)."""
    run = simulate_people(PeopleSimConfig(seed=1, duration=40.0, legs=legs))
    tracks: dict[int, list[np.ndarray]] = {}
    for ids, positions in run.people:
        for ident, position in zip(ids.tolist(), positions):
            tracks.setdefault(ident, []).append(position)
    reversed_steps = walking_steps = 0
    for track in tracks.values():
        steps = np.diff(np.array(track), axis=0)
        walking = np.linalg.norm(steps, axis=1) > 0.02
        both = walking[1:] & walking[:-1]
        reversed_steps += int(np.sum(both & (np.sum(steps[1:] * steps[:-1], axis=1) < 0.0)))
        walking_steps += int(np.sum(both))
    assert walking_steps > 1000
    assert reversed_steps < 0.01 * walking_steps


def test_plain_world_is_unchanged_by_the_legs_option():
    a = simulate_people(PeopleSimConfig(seed=3, duration=3.0))
    b = simulate_people(PeopleSimConfig(seed=3, duration=3.0, legs=False))
    for x, y in zip(a.scans, b.scans):
        np.testing.assert_array_equal(x, y)


def test_mixed_pixels_lie_between_the_two_surfaces_of_an_edge():
    ranges = np.array([1.0, 1.0, 1.0, 5.0, 5.0, 5.0, 1.2, 1.2, np.inf, 3.0])
    rng = np.random.default_rng(0)
    np.testing.assert_array_equal(mix_edges(ranges, 0.0, rng), ranges)
    mixed = [mix_edges(ranges, 1.0, rng) for _ in range(2000)]
    for r in mixed:     # the nearer beam of each edge; a beam beside no return is no edge
        assert set(np.flatnonzero(r != ranges).tolist()) <= {2, 6}
        assert 1.0 <= r[2] <= 5.0 and 1.2 <= r[6] <= 5.0
    assert np.mean([r[2] for r in mixed]) == pytest.approx(3.0, abs=0.1)   # uniform
    changed = np.mean([(mix_edges(ranges, 0.5, rng) != ranges).sum() for _ in range(2000)])
    assert changed == pytest.approx(1.0, abs=0.1)    # two edges, each at one half


def test_clear_mot_counts_at_the_benchmark_radius():
    truth = [Frame(0.0, np.array([1]), np.array([[0.0, 0.0]]))]
    track = [Frame(0.0, np.array([5]), np.array([[0.6, 0.0]]))]
    at_half = clear_mot(truth, track, 0.5)
    at_benchmark = clear_mot(truth, track, 0.75)
    assert (at_half["misses"], at_half["false_positives"]) == (1, 1)
    assert at_half["mota"] == -1.0
    assert (at_benchmark["misses"], at_benchmark["false_positives"]) == (0, 0)
    assert at_benchmark["mota"] == 1.0 and at_benchmark["motp"] == 0.6


# ---------------------------------------------------------------- the leg detector

LEGS = LegModel(leg_radius=0.06, max_leg_width=0.25, max_leg_spacing=0.5,
                max_person_width=1.0, min_beams=2)


def _detect(circles: list[tuple[float, float, float]], beams: int = 720,
            noise: float = 0.0, seed: int = 0, lone_legs: bool = True) -> np.ndarray:
    """(P, 2) sensor-frame people detected by ``detect_legs`` in a scan from the origin of
    circles (x, y, radius) in open space (every return dynamic)."""
    angles = -math.pi + (np.arange(beams) + 0.5) * (2.0 * math.pi / beams)
    ranges = np.full(beams, np.inf)
    for x, y, r in circles:
        ranges = np.minimum(ranges, people_legs.circle_ranges(
            np.zeros(3), angles, np.array([[x, y]]), r))
    ranges = ranges + np.random.default_rng(seed).normal(0.0, noise, beams)
    scan = Scan(ranges, float(angles[0]), float(angles[1] - angles[0]), 12.0)
    returns = scan.returns(0.05, 12.0)
    segments = segment_scan(scan, returns, 0.3)
    found = detect_legs(segments, np.ones((1, len(segments.beams)), bool), 0, LEGS,
                        np.where(returns, ranges, np.inf),
                        scan.angle_increment if lone_legs else None)
    valid = found.valid[0]
    return np.stack([found.ranges[0, valid] * np.cos(found.bearings[0, valid]),
                     found.ranges[0, valid] * np.sin(found.bearings[0, valid])], axis=1)


def test_range_toward_a_bearing_is_its_nearest_beams_with_no_return_as_inf():
    """Beams at 0, 0.5, 1, 1.5 rad: NaN stays NaN (no evidence), a range below min_range is no
    return (inf), a bearing takes its nearest beam."""
    scan = Scan(np.array([np.nan, np.inf, 0.05, 3.0]), 0.0, 0.5)
    np.testing.assert_array_equal(scan.range_toward(np.array([0.1, 0.4, 1.1, 1.6]), 0.1),
                                  [np.nan, np.inf, np.inf, 3.0])


def test_beams_needed_drop_to_what_one_leg_returns_beyond_its_two_beam_range():
    """0.12 m at 1 degree spans two beams up to 0.12 / (2 x 0.01745) = 3.44 m: two needed
    there, one beyond; never fewer than one nor more than min_beams."""
    step = math.radians(1.0)
    ranges = np.array([0.3, 3.4, 3.5, 6.0, 20.0])
    np.testing.assert_array_equal(beams_needed(2, 0.12, ranges, step), [2, 2, 1, 1, 1])
    np.testing.assert_array_equal(beams_needed(3, 0.12, ranges, step), [3, 2, 1, 1, 1])
    np.testing.assert_array_equal(beams_needed(1, 0.12, ranges, step), [1, 1, 1, 1, 1])


@pytest.mark.parametrize("distance, radius, lone_legs, found", [
    (8.0, 0.06, True, True),     # a leg at 8 m: 0.14 m between beams, it returns one
    (3.0, 0.01, True, False),    # a 2 cm rod at 3 m returns one beam where a leg returns two
    (8.0, 0.06, False, False),   # a laser with mixed pixels: a lone return is not a leg
])
def test_a_lone_leg_far_away_is_a_person_from_one_beam_but_a_rod_near_is_not(
        distance, radius, lone_legs, found):
    bearing = math.radians(0.5)                               # on a beam of the 360
    people = _detect([(distance * math.cos(bearing), distance * math.sin(bearing), radius)],
                     beams=360, lone_legs=lone_legs)
    assert len(people) == (1 if found else 0)


def test_a_lone_leg_beside_a_nearer_object_needs_two_beams():
    """The leg at 8 m of the test above, a thin rod at 2.5 m on the next beam: the rest of
    the person may be behind the rod, so its one beam is not enough (and the rod's one beam
    at 2.5 m is no person either)."""
    leg, rod = math.radians(0.5), math.radians(1.5)
    people = _detect([(8.0 * math.cos(leg), 8.0 * math.sin(leg), 0.06),
                      (2.5 * math.cos(rod), 2.5 * math.sin(rod), 0.03)], beams=360)
    assert len(people) == 0


def test_two_legs_are_one_person_at_their_midpoint():
    # legs 0.25 m apart across the line of sight at 3 m: the person is the midpoint (3, 0.5)
    people = _detect([(3.0, 0.375, 0.06), (3.0, 0.625, 0.06)])
    assert people.shape == (1, 2)
    np.testing.assert_allclose(people[0], [3.0, 0.5], atol=0.015)


def test_one_leg_alone_is_a_person_at_the_leg():
    people = _detect([(-2.0, -2.0, 0.06)])
    assert people.shape == (1, 2)
    np.testing.assert_allclose(people[0], [-2.0, -2.0], atol=0.015)


def test_two_people_side_by_side_are_two_people():
    left = [(4.0, 0.2, 0.06), (4.1, 0.42, 0.06)]     # centre (4.05, 0.31)
    right = [(4.0, -0.35, 0.06), (3.9, -0.57, 0.06)]   # centre (3.95, -0.46)
    people = _detect(left + right)
    assert people.shape == (2, 2)
    order = np.argsort(-people[:, 1])
    np.testing.assert_allclose(people[order], [[4.05, 0.31], [3.95, -0.46]], atol=0.02)


def test_mixed_pixels_beside_mapped_objects_or_far_behind_a_leg_are_not_dynamic():
    ranges = np.array([1.0, 1.0, 3.0, 5.0, 5.0, 3.2, 1.2, 1.25, np.inf, 2.0, np.inf, 4.0,
                       4.2, 6.0])
    np.testing.assert_array_equal(np.flatnonzero(mixed_pixels(ranges, 0.3)), [2, 5])
    # a wall at 8 m, 0.5-degree beams (a leg spans two of them up to 6.9 m); lone returns
    # (free space: dynamic by the map) beside a mapped post at 5 m, 0.4 m behind a leg (its
    # other leg), 3 m behind a leg at 3 m (mixed) and 0.6 m behind a leg at 7 m (a leg there
    # returns a single beam)
    increment = 2.0 * math.pi / 720
    ranges = np.full(720, np.inf)
    ranges[300:500] = 8.0
    ranges[329:332] = [5.5, 5.0, 5.9]
    ranges[389:392] = [5.0, 5.0, 5.4]
    ranges[429:432] = [3.0, 3.0, 6.0]
    ranges[469:472] = [7.0, 7.0, 7.6]
    scan = Scan(ranges, -math.pi + 0.5 * increment, increment, 12.0)
    segments = segment_scan(scan, scan.returns(0.05, 12.0), 0.3)
    dynamic = [329, 331, 389, 390, 391, 429, 430, 431, 469, 470, 471]
    far = np.isin(segments.beams, dynamic)[None]
    kept = without_mixed_pixels(far, segments, ranges, mixed_pixels(ranges, 0.3), 0.5,
                                0.06 / increment)
    np.testing.assert_array_equal(segments.beams[kept[0]],
                                  [389, 390, 391, 429, 430, 469, 470, 471])


def test_static_edges_count_depth_edges_and_the_lone_returns_in_free_space_that_bridge_them():
    # static surfaces at 1 m and 5 m; a lone dynamic return at 3 m bridges one edge, a leg
    # (two dynamic beams) in front of the far wall bridges nothing, a 0.5 m step is no edge
    ranges = np.array([1.0, 1.0, 3.0, 5.0, 5.0, 2.0, 2.0, 5.0, 5.0, 1.0, 1.0, 1.5, 1.5])
    dynamic = np.zeros(len(ranges), bool)
    dynamic[[2, 5, 6]] = True
    # edges: 1|3|5 (bridged), 5|1 at beams 8-9 (direct); 5|2 and 2|5 touch the leg
    lone = mixed_pixels(ranges, 0.3)
    assert static_edges(ranges, dynamic, lone, 0.3) == (2, 1)
    # the same lone return taken for static (a mapped post at 3 m) makes two edges of one
    assert static_edges(ranges, np.isin(np.arange(len(ranges)), [5, 6]), lone, 0.3) == (3, 0)


@pytest.mark.parametrize("probability", [0.0, 0.1, 0.5])
def test_the_mixed_pixel_monitor_measures_the_simulated_lasers_rate(probability):
    """Edges between 1 m and 5 m surfaces, each nearer beam a mixed pixel (uniform between
    the surfaces) with probability P (``mix_edges``). A mixed pixel within ``jump`` of either
    surface joins it and its edge is counted in neither sum, so the share is
    0.85 P / (1 - 0.15 P) (0.6 m of the 4 m between them). ``auto`` filters until it has
    seen MIXED_PIXEL_EDGES edges, then above MIXED_PIXEL_SHARE only."""
    rng = np.random.default_rng(7)
    ranges = np.tile(np.repeat([1.0, 5.0], 10), 36)
    monitor = MixedPixelMonitor()
    for _ in range(200):
        mixed = mix_edges(ranges, probability, rng)
        segments = segment_scan(Scan(mixed, 0.0, 2.0 * math.pi / len(ranges), 12.0),
                                np.ones(len(ranges), bool), 0.3)
        monitor.observe(mixed, mixed_pixels(mixed, 0.3), segments,
                        ~np.isin(mixed[segments.beams], [1.0, 5.0]), 0.3)
    expected = 0.85 * probability / (1.0 - 0.15 * probability)
    assert monitor.edges > 10_000
    assert monitor.share == pytest.approx(expected, abs=0.01)
    assert monitor.filtering == (probability > 0.0)
    fresh, few = MixedPixelMonitor(), mixed[:40]
    segments = segment_scan(Scan(few, 0.0, 0.01, 12.0), np.ones(40, bool), 0.3)
    fresh.observe(few, mixed_pixels(few, 0.3), segments,
                  ~np.isin(few[segments.beams], [1.0, 5.0]), 0.3)
    assert fresh.edges < MIXED_PIXEL_EDGES and fresh.filtering    # too few edges to judge
    assert MixedPixelMonitor("always").filtering and not MixedPixelMonitor("never").filtering


def test_a_round_body_is_one_person_at_its_centre():
    people = _detect([(2.5, 1.0, 0.2)])
    assert people.shape == (1, 2)
    np.testing.assert_allclose(people[0], [2.5, 1.0], atol=0.02)


def test_leg_positions_are_not_biased_away_from_the_laser():
    # noisy ranges (0.02 m) at 1-6 m: the mean error along the line of sight is near zero,
    # where the nearest return plus a person radius is about 0.1 m too far
    rng = np.random.default_rng(5)
    along = []
    for seed in range(40):
        distance, bearing = rng.uniform(1.0, 6.0), rng.uniform(-math.pi, math.pi)
        centre = distance * np.array([math.cos(bearing), math.sin(bearing)])
        forward = np.array([-math.sin(bearing), math.cos(bearing)])
        legs = [tuple(centre + sign * 0.12 * forward) + (0.06,) for sign in (-1, 1)]
        people = _detect(legs, beams=1080, noise=0.02, seed=seed)
        if len(people) == 1:
            along.append((people[0] - centre) @ (centre / distance))
    assert len(along) >= 35
    assert abs(np.mean(along)) < 0.02


# ---------------------------------------------------------------- dynamic evidence near the map

def _legs_scan(grid: OccupancyMap, pose, legs, beams: int = 720) -> Scan:
    """A scan of the grid and the legs (x, y) (radius 0.06), ``beams`` beams, no noise."""
    angles = -math.pi + (np.arange(beams) + 0.5) * (2.0 * math.pi / beams)
    world = pose[2] + angles
    ranges = grid.cast(np.broadcast_to(np.asarray(pose[:2], float), (beams, 2)), world, 12.0)
    ranges = np.minimum(ranges, people_legs.circle_ranges(np.asarray(pose, float), world,
                                                          np.asarray(legs, float), 0.06))
    return Scan(ranges, float(angles[0]), float(angles[1] - angles[0]), 12.0)


def _people_seen(short_margin: float, legs, scans: int = 4, pose=(4.0, 4.0, 0.0),
                 beams: int = 720, **settings) -> np.ndarray:
    cells = 160
    centres = (np.arange(cells) + 0.5) * 0.05
    x, y = np.meshgrid(centres, centres)
    occupied = (x < 0.15) | (x > 7.85) | (y < 0.15) | (y > 7.85)
    grid = OccupancyMap(occupied, ~occupied, 0.05)
    tracker = PeopleTracker(TrackerSettings(num_particles=5, people_particles=30, seed=1,
                                            short_margin=short_margin, **settings), grid)
    tracker.reset(np.array(pose), np.diag([1e-8, 1e-8, 1e-10]))
    for k in range(scans):
        tracker.update(0.1 * k, _legs_scan(grid, pose, legs, beams))
    return tracker.published_people().means


def test_a_person_against_a_wall_is_seen_by_the_expected_range():
    # legs 0.1 m from the right wall's face (x = 7.85): every return within 0.3 m of the
    # wall, 0.16-0.22 m short of it along the beams
    legs = [(7.69, 3.9), (7.69, 4.1)]
    seen = _people_seen(0.15, legs)
    assert len(seen) == 1
    np.testing.assert_allclose(seen[0], [7.69, 4.0], atol=0.05)
    assert len(_people_seen(0.0, legs)) == 0     # by the distance rule alone: invisible
    # a person in the open is seen either way, at its place
    for margin in (0.0, 0.15):
        seen = _people_seen(margin, [(5.5, 2.4), (5.5, 2.6)])
        assert len(seen) == 1
        np.testing.assert_allclose(seen[0], [5.5, 2.5], atol=0.05)


def test_the_walls_alone_are_not_people_by_the_expected_range():
    assert len(_people_seen(0.15, np.zeros((0, 2)))) == 0


def test_a_beam_that_clips_a_corner_is_not_dynamic_one_two_cells_beside_it_is():
    # a 0.4 m block, x and y in [4.0, 4.4]; a beam from below left that passes just above
    # its top left corner and ends (range noise) in the free cell diagonal to the corner cell:
    # the map predicts no obstacle beyond that end, yet it is the corner. The same beam
    # ending one cell farther from the corner (a leg beside the block) is dynamic.
    centres = (np.arange(160) + 0.5) * 0.05
    x, y = np.meshgrid(centres, centres)
    occupied = (x > 4.0) & (x < 4.4) & (y > 4.0) & (y < 4.4)
    grid = OccupancyMap(occupied, ~occupied, 0.05)
    sensor = np.array([[3.0, 3.6, 0.0]])
    ends = np.array([[[3.99, 4.41], [3.93, 4.36]]])
    angles = np.arctan2(ends[0, :, 1] - 3.6, ends[0, :, 0] - 3.0)
    distances = grid.distance_at(ends)
    np.testing.assert_allclose(distances[0], [0.05 * math.sqrt(2.0), 0.1], atol=1e-6)
    assert np.isinf(grid.cast(ends[0], angles, 0.15)).all()   # nothing beyond either end
    dynamic = dynamic_beams(grid, sensor, ends, distances, angles, 0.3, 0.15)
    np.testing.assert_array_equal(dynamic, [[False, True]])


def test_two_legs_are_published_at_once_one_leg_after_two_detections():
    pair, leg = [(5.5, 2.4), (5.5, 2.6)], [(5.5, 2.4)]
    # log-odds: a new person starts at tau+ = 1 < logodds_confirm = 1.5; a pair of legs
    # starts at logodds_confirm - tau+ first, reaching it with its first detection
    assert len(_people_seen(0.15, pair, scans=1)) == 1
    assert len(_people_seen(0.15, pair, scans=1, confirm_pairs=False,
                            confirm_clear=False)) == 0
    assert len(_people_seen(0.15, leg, scans=1, confirm_clear=False)) == 0
    assert len(_people_seen(0.15, leg, scans=2, confirm_clear=False)) == 1
    assert len(_people_seen(0.15, pair, scans=2, confirm_pairs=False)) == 1


def test_one_leg_beyond_the_one_beam_range_is_published_at_once_nearer_after_two():
    """At 1-degree beams a leg (0.12 m) returns at most one beam beyond 6.9 m, and the beam
    spacing misses it in some scans: a new person seen there is published at its first
    detection (``confirm_far``); a leg alone nearer waits for a second detection; the
    mixed-pixel filter, on over a laser's first scans, would take the far beam for one."""
    pose = (0.6, 0.6, 0.0)
    bearing = math.radians(-180.0 + 225.5)          # the middle of beam 225 of 360
    seen = partial(_people_seen, 0.15, pose=pose, beams=360, mixed_pixel_filter="never",
                   confirm_clear=False)    # the open floor's rule apart
    for distance, at_once in ((9.0, True), (5.0, False)):
        reach = distance + 0.06                      # the beam ends on the leg's front
        leg = [(pose[0] + reach * math.cos(bearing), pose[1] + reach * math.sin(bearing))]
        assert len(seen(leg, scans=1)) == int(at_once), distance
        assert len(seen(leg, scans=1, confirm_far=False)) == 0
        assert len(seen(leg, scans=2)) == 1


def test_one_leg_on_open_floor_is_published_at_once_with_confirm_clear_beside_a_wall_not():
    """``confirm_clear``: a lone leg more than max_leg_spacing (0.5 m) from every mapped
    obstacle is published at its first detection; one 0.35 m from the wall's face waits for a
    second detection, as every lone leg does without it. The mixed-pixel filter, on over a
    laser's first scans, would hold it back (a lone mixed pixel stands in free space)."""
    seen = partial(_people_seen, 0.15, mixed_pixel_filter="never")
    open_floor, by_the_wall = [(5.5, 2.4)], [(7.5, 4.0)]
    assert len(seen(open_floor, scans=1)) == 1
    assert len(seen(open_floor, scans=1, confirm_clear=False)) == 0
    assert len(seen(by_the_wall, scans=1)) == 0
    assert len(seen(by_the_wall, scans=2)) == 1
    assert len(_people_seen(0.15, open_floor, scans=1, mixed_pixel_filter="always")) == 0


def test_a_270_degree_laser_at_7_5_hz_is_simulated_and_scored_within_its_span():
    """The real recording's laser: 540 beams over 270 degrees, 7.5 scans a second (with
    odometry at 60 Hz). The beams span +-135 degrees evenly; the scorer counts a person
    ahead and to the left as in view and one behind the laser as not."""
    span = 1.5 * math.pi
    config = PeopleSimConfig(seed=1, duration=4.0, legs=True, beams=540, field_of_view=span,
                             scan_rate=7.5, odometry_rate=60.0)
    run = simulate_people(config)
    assert len(run.scans) == 31 and len(run.scans[0]) == 540
    np.testing.assert_allclose(run.angles[[0, -1]], [-span / 2 + span / 1080,
                                                     span / 2 - span / 1080])
    np.testing.assert_allclose(np.diff(run.angles), span / 540)
    view = people_eval.LaserView(12.0, Scan(np.zeros(540), float(run.angles[0]),
                                            float(run.angles[1] - run.angles[0])))
    walls = np.zeros((100, 100), bool)          # an empty 5 m x 5 m room
    walls[[0, -1], :] = walls[:, [0, -1]] = True
    grid = OccupancyMap(walls, ~walls, 0.05)
    pose = np.array([2.5, 2.5, 0.0])
    points = pose[:2] + np.array([[1.5, 0.0], [0.0, 1.5], [-1.5, 0.0]])
    np.testing.assert_array_equal(people_eval.visible(grid, pose, points, view),
                                  [True, True, False])
    with pytest.raises(ValueError, match="field_of_view"):
        PeopleSimConfig(field_of_view=7.0).validate()
    with pytest.raises(ValueError, match="mixed_pixels"):
        PeopleSimConfig(mixed_pixels=1.5).validate()


def test_auto_filters_mixed_pixels_only_for_a_laser_that_returns_them():
    """Posts (mapped furniture) before the walls of a room, and a laser whose every depth
    edge returns a mixed pixel (``mix_edges`` at P = 1): with ``never`` the lone points in
    free space are tracked as people; ``auto`` measures the laser's share of bridged edges
    and filters as ``always`` does. With a clean laser ``auto`` measures no mixed pixel and
    stops filtering after its first scans: it tracks what ``never`` tracks."""
    centres = (np.arange(160) + 0.5) * 0.05
    x, y = np.meshgrid(centres, centres)
    occupied = (x < 0.15) | (x > 7.85) | (y < 0.15) | (y > 7.85)
    for post in [(2.0, 2.0), (2.0, 6.0), (6.0, 2.0), (6.0, 6.0), (1.5, 4.0)]:
        occupied |= np.hypot(x - post[0], y - post[1]) < 0.15
    grid = OccupancyMap(occupied, ~occupied, 0.05)
    pose = np.array([4.0, 4.0, 0.0])

    def published(mode: str, probability: float, legs) -> tuple[list[int], PeopleTracker]:
        """People published after each of 20 scans."""
        rng = np.random.default_rng(3)
        tracker = PeopleTracker(TrackerSettings(num_particles=5, people_particles=30, seed=1,
                                                mixed_pixel_filter=mode), grid)
        tracker.reset(pose, np.diag([1e-8, 1e-8, 1e-10]))
        counts = []
        for k in range(20):
            scan = _legs_scan(grid, pose, legs)
            scan = Scan(mix_edges(scan.ranges, probability, rng), scan.angle_min,
                        scan.angle_increment, 12.0)
            tracker.update(0.1 * k, scan)
            counts.append(len(tracker.published_people().keys))
        return counts, tracker

    never, _ = published("never", 1.0, [])
    auto, tracker = published("auto", 1.0, [])
    assert auto == published("always", 1.0, [])[0]
    assert sum(never) > 3 * sum(auto) and max(never[5:]) >= 3
    assert tracker.mixed_pixels.share > 0.5 and tracker.mixed_pixels.filtering
    person = [(5.0, 3.0), (5.0, 3.2)]
    auto, tracker = published("auto", 0.0, person)
    assert auto == published("never", 0.0, person)[0] and auto[-1] == 1
    assert tracker.mixed_pixels.share == 0.0 and not tracker.mixed_pixels.filtering


def test_a_swept_scan_deskewed_puts_each_beam_where_it_ended():
    """A laser turning at 0.8 rad/s in place (``sweep_poses``) takes its 540 beams over
    270 degrees at 7.5 Hz, each from its own heading. Seen from the first beam's pose with
    the scan's own bearings, the last beam ends land a quarter metre off where they hit;
    ``deskewed`` at the turn rate puts every one where it ended."""
    room = np.zeros((160, 160), bool)
    room[[0, -1], :] = room[:, [0, -1]] = True
    grid = OccupancyMap(room, ~room, 0.05)
    config = PeopleSimConfig(beams=540, field_of_view=1.5 * math.pi, scan_rate=7.5, sweep=True)
    angles = -0.75 * math.pi + (np.arange(540) + 0.5) * (1.5 * math.pi / 540)
    start = np.array([3.0, 5.0, 0.4])
    poses = sweep_poses(start, 0.0, 0.8, 540, config.time_increment)
    assert config.time_increment * 540 == pytest.approx(0.1)    # 270 of 360 degrees, 7.5 Hz
    ranges = cast_scan(grid, poses, angles, np.zeros((0, 2)), 12.0)
    true_ends = poses[:, :2] + ranges[:, None] * np.stack(
        [np.cos(poses[:, 2] + angles), np.sin(poses[:, 2] + angles)], axis=1)
    scan = Scan(ranges, float(angles[0]), float(angles[1] - angles[0]), 12.0,
                config.time_increment)

    def ends(seen: Scan) -> np.ndarray:
        heading = start[2] + seen.angles
        return start[:2] + seen.ranges[:, None] * np.stack([np.cos(heading), np.sin(heading)], 1)
    assert np.linalg.norm(ends(scan) - true_ends, axis=1).max() > 0.2
    np.testing.assert_allclose(ends(deskewed(scan, 0.8)), true_ends, atol=1e-9)
    assert deskewed(Scan(ranges, scan.angle_min, scan.angle_increment), 0.8).angle_increment \
        == scan.angle_increment                                     # no timing: as it is


def test_a_scan_swept_while_driving_deskewed_puts_each_return_within_half_a_beam_of_its_point():
    """The same laser driving at 0.5 m/s while it turns: its travel in the sweep (5 cm)
    moves the returns off the evenly spaced bearings. ``deskewed`` with the velocity places
    every return at its point, in the nearest beam: within half a beam's spacing of where it
    ended, where the turn alone leaves up to the travel."""
    from scipy.spatial import cKDTree
    room = np.zeros((160, 160), bool)
    room[[0, -1], :] = room[:, [0, -1]] = True
    room[60:64, 70:74] = True                        # a post 2 m ahead: a near depth edge
    grid = OccupancyMap(room, ~room, 0.05)
    increment = 1.5 * math.pi / 540
    time_increment = PeopleSimConfig(beams=540, field_of_view=1.5 * math.pi, scan_rate=7.5,
                                     sweep=True).time_increment
    angles = -0.75 * math.pi + (np.arange(540) + 0.5) * increment
    start = np.array([1.6, 3.0, 0.0])
    poses = sweep_poses(start, 0.5, 0.8, 540, time_increment)
    ranges = cast_scan(grid, poses, angles, np.zeros((0, 2)), 12.0)
    hit = np.isfinite(ranges)
    true_ends = (poses[:, :2] + ranges[:, None] * np.stack(
        [np.cos(poses[:, 2] + angles), np.sin(poses[:, 2] + angles)], axis=1))[hit]
    scan = Scan(ranges, float(angles[0]), increment, 12.0, time_increment)

    def worst(seen: Scan) -> float:
        kept = np.isfinite(seen.ranges)
        heading = start[2] + seen.angles[kept]
        ends = start[:2] + seen.ranges[kept, None] * np.stack([np.cos(heading),
                                                               np.sin(heading)], 1)
        distance, _ = cKDTree(true_ends).query(ends)
        bound = 0.5 * abs(seen.angle_increment) * seen.ranges[kept] + 0.005
        return float(np.max(distance / bound))
    assert worst(deskewed(scan, 0.8)) > 2.0
    assert worst(deskewed(scan, 0.8, (0.5, 0.0))) < 1.0
    assert np.isfinite(deskewed(scan, 0.8, (0.5, 0.0)).ranges).sum() > 0.9 * hit.sum()


def test_sweep_poses_follow_the_unicycle_and_circles_are_cast_from_each_beams_pose():
    start = np.array([1.0, 2.0, 0.3])
    poses = sweep_poses(start, 0.5, 0.8, 11, 0.01)
    pose, dt = start.copy(), 1e-5                    # the unicycle integrated finely
    for _ in range(10_000):
        pose += dt * np.array([0.5 * math.cos(pose[2]), 0.5 * math.sin(pose[2]), 0.8])
    np.testing.assert_allclose(poses[-1], pose, atol=1e-5)
    straight = sweep_poses(start, 0.5, 0.0, 3, 0.1)[:, :2]
    np.testing.assert_allclose(straight, start[:2] + np.outer([0.0, 0.05, 0.1],
                                                              [math.cos(0.3), math.sin(0.3)]))
    angles = np.linspace(-0.5, 0.5, 50)
    centres = np.array([[4.0, 2.5], [3.0, 1.2]])
    one = people_legs.circle_ranges(start, start[2] + angles, centres, 0.2)
    each = people_legs.circle_ranges(np.tile(start, (50, 1)), start[2] + angles, centres, 0.2)
    np.testing.assert_allclose(each, one, atol=1e-12)
    assert np.isfinite(one).sum() > 5


def test_a_swept_simulated_scan_takes_its_first_beam_at_the_stamp_and_says_how_far_apart():
    """``--sweep``: the first beam of each scan is the one taken all at once, the others are
    taken from where the driving robot is later (so they differ), and the LaserScan carries
    the time between beams: a full turn of the mirror per scan period."""
    swept = simulate_people(PeopleSimConfig(seed=1, duration=1.0, people=0, sweep=True))
    still = simulate_people(PeopleSimConfig(seed=1, duration=1.0, people=0))
    config = PeopleSimConfig(sweep=True)
    assert config.time_increment == pytest.approx(1.0 / (10.0 * 360))
    for a, b in zip(swept.scans[1:], still.scans[1:]):
        assert a[0] == b[0]                  # the same beam, the same noise drawn
        both = np.isfinite(a) & np.isfinite(b)
        later = np.abs(a[both] - b[both])[both.sum() // 2:]
        assert later.max() > 0.01                     # the later beams, from farther on
    message = laser_scan_message(0.0, swept.scans[0], swept.angles, 12.0,
                                 time_increment=config.time_increment)
    assert message.time_increment == pytest.approx(config.time_increment)
