# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The simulated laser against closed forms, the pole world's layout, ``fastslam-sim --laser``
and the extractor on simulated scans against the known poles."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fastslam_ros.extractor import ExtractorSettings, RawScan, extract_landmarks
from fastslam_ros.tools.simulation import sim
from fastslam_ros.tools.bags.bag_schema import bag_topics, read_topic
from fastslam_ros.tools.evaluation.extractor_eval import Tally, evaluate_seed, visible_poles
from fastslam_ros.tools.simulation.laser_sim import (POLE_CLEARANCE, REFLECTOR_GAIN, Laser,
                                                     PoleWorld, pole_world, segment_distance)

LASER = Laser()


def small_world(reflective=False) -> PoleWorld:
    return PoleWorld(np.array([[10.0, 0.0]]), np.array([0.2]), np.array([reflective]),
                     np.array([[5.0, -20.0, 5.0, -2.0], [-3.0, -10.0, -3.0, 10.0]]))


def test_cast_hits_pole_and_walls_at_their_closed_form_ranges():
    ranges, incidence, pole = LASER.cast(small_world(), np.array([0.0, 0.0, 0.0]))
    centre = LASER.beams // 2
    assert LASER.angles[centre] == pytest.approx(0.0, abs=1e-12)
    assert ranges[centre] == pytest.approx(9.8, abs=1e-9) and pole[centre] == 0
    assert incidence[centre] == pytest.approx(1.0)
    # The wall x = 5 (y in [-20, -2]) at bearing -60 degrees: range 5 / cos(60 deg) = 10.
    beam = int(np.argmin(np.abs(LASER.angles + math.radians(60.0))))
    assert ranges[beam] == pytest.approx(5.0 / math.cos(LASER.angles[beam]), abs=1e-9)
    assert incidence[beam] == pytest.approx(math.cos(LASER.angles[beam]), abs=1e-9)
    assert pole[beam] == -1
    # The wall behind at x = -3 (135 degrees is within the 270-degree view): 3 / cos(45 deg).
    beam = int(np.argmin(np.abs(LASER.angles - math.radians(135.0))))
    assert ranges[beam] == pytest.approx(3.0 / abs(math.cos(LASER.angles[beam])), abs=1e-9)
    # Beams that miss everything within max_range are +inf (REP 117).
    beam = int(np.argmin(np.abs(LASER.angles - math.radians(60.0))))
    assert ranges[beam] == math.inf


def test_reflective_pole_is_brighter_and_noise_has_its_spread():
    rng = np.random.default_rng(0)
    pose = np.array([0.0, 0.0, 0.0])
    truth, _, pole = LASER.cast(small_world(), pose)
    noisy, plain = zip(*(LASER.scan(small_world(), pose, rng) for _ in range(200)))
    hit = np.isfinite(truth)
    residuals = (np.array(noisy)[:, hit] - truth[hit]).ravel()
    assert np.std(residuals) == pytest.approx(LASER.sigma_range, rel=0.05)
    _, bright = LASER.scan(small_world(reflective=True), pose, rng)
    on_pole = pole == 0
    ratio = np.median(bright[on_pole]) / np.median(np.array(plain)[:, on_pole])
    assert ratio == pytest.approx(REFLECTOR_GAIN, rel=0.1)
    assert np.all(np.array(plain)[:, ~hit] == 0.0)


def test_pole_world_keeps_walls_and_cars_clear_of_poles_and_is_seeded():
    config = sim.SimConfig(seed=1).resolved()
    world = sim.build_world(config)
    poles = pole_world(config.world_seed, world.landmarks.positions, world.waypoints)
    assert len(poles.centres) == config.num_landmarks and poles.reflective.any()
    clearance = segment_distance(poles.centres, poles.walls) - poles.radii
    assert clearance.min() >= POLE_CLEARANCE
    again = pole_world(config.world_seed, world.landmarks.positions, world.waypoints)
    assert np.array_equal(again.walls, poles.walls) and np.array_equal(again.radii, poles.radii)


def test_fastslam_sim_laser_writes_scans_beside_the_landmark_clouds(tmp_path):
    out = tmp_path / "laser_bag"
    assert sim.main(["--laser", "--duration", "4", "--seed", "2", "--out", str(out)]) == 0
    assert bag_topics(out)["/scan"] == "sensor_msgs/msg/LaserScan"
    scan_stamps, scans = read_topic(out, "/scan")
    cloud_stamps, _ = read_topic(out, "/landmarks")
    assert np.array_equal(scan_stamps, cloud_stamps)
    first = scans[0]
    assert len(first.ranges) == LASER.beams == len(first.intensities)
    assert first.header.frame_id == "base_link"
    assert first.angle_min == pytest.approx(-0.75 * math.pi)
    assert first.time_increment == 0.0
    plain = tmp_path / "plain_bag"
    assert sim.main(["--duration", "4", "--out", str(plain)]) == 0
    assert "/scan" not in bag_topics(plain)
    assert sim.main(["--sweep", "--duration", "4", "--out", str(tmp_path / "no")]) == 2
    swept = tmp_path / "swept_bag"
    assert sim.main(["--laser", "--sweep", "--duration", "4", "--seed", "2",
                     "--out", str(swept)]) == 0
    _, swept_scans = read_topic(swept, "/scan")
    # A full turn of the mirror per reading period (5 Hz): 270 degrees take 0.15 s; the first
    # beam is taken at the stamp, as without the sweep.
    sweep = swept_scans[0].time_increment * (LASER.beams - 1)
    assert sweep == pytest.approx(0.75 / 5.0, rel=1e-6)
    assert swept_scans[3].ranges[0] == pytest.approx(scans[3].ranges[0], abs=0.05)


def test_fastslam_sim_laser_mixed_pixels_lie_between_the_two_surfaces_of_an_edge(tmp_path):
    """With --mixed-pixels 1 every depth edge's nearer beam returns a range between the two
    surfaces and no other beam changes; 0 writes the scans of a laser without them."""
    scans = {}
    for name, extra in (("plain", []), ("zero", ["--mixed-pixels", "0"]),
                        ("mixed", ["--mixed-pixels", "1"])):
        out = tmp_path / name
        assert sim.main(["--laser", "--duration", "2", "--seed", "2", "--out", str(out)]
                        + extra) == 0
        scans[name] = [np.asarray(m.ranges, float) for m in read_topic(out, "/scan")[1]]
    changed = 0
    for plain, zero, mixed in zip(scans["plain"], scans["zero"], scans["mixed"]):
        assert np.array_equal(plain, zero)
        moved = np.flatnonzero(plain != mixed)
        for beam in moved:
            neighbours = [plain[b] for b in (beam - 1, beam + 1) if 0 <= b < len(plain)]
            farther = [r for r in neighbours if np.isfinite(r) and r > plain[beam] + 0.3]
            assert farther, "only the nearer beam of a depth edge changes"
            assert plain[beam] <= mixed[beam] <= max(farther)
        changed += len(moved)
    assert changed > 100
    assert sim.main(["--duration", "2", "--out", str(tmp_path / "no"),
                     "--mixed-pixels", "0.5"]) == 2                      # without --laser
    with pytest.raises(SystemExit) as usage:                             # argparse's error
        sim.main(["--laser", "--mixed-pixels", "1.5", "--out", str(tmp_path / "no")])
    assert usage.value.code == 2


def test_extractor_finds_the_fully_visible_simulated_poles():
    """One simulated scan per second along 60 s of the loop: >= 95 % of the fully visible
    poles spanning >= 3 beams found, within 0.03 m + 1 % of their range; no false ones."""
    config = sim.SimConfig(seed=3, duration=60.0).resolved()
    world = sim.build_world(config)
    bag = sim.simulate(config)
    poles = pole_world(config.world_seed, world.landmarks.positions, world.waypoints)
    settings = ExtractorSettings().validate()
    rng = np.random.default_rng(5)
    visible = found = false = 0
    for pose in np.asarray(bag.ground_truth.poses)[::40]:
        ranges, intensities = LASER.scan(poles, pose, rng)
        truth, _, hit = LASER.cast(poles, pose)
        scan = RawScan(ranges, float(LASER.angles[0]),
                       float(LASER.angles[1] - LASER.angles[0]), 0.05, 30.0, intensities)
        landmarks = extract_landmarks(scan, settings).landmarks
        c, s = math.cos(pose[2]), math.sin(pose[2])
        offset = poles.centres - pose[:2]
        local = np.column_stack([c * offset[:, 0] + s * offset[:, 1],
                                 -s * offset[:, 0] + c * offset[:, 1]])
        gaps = np.hypot(landmarks.x[:, None] - local[None, :, 0],
                        landmarks.y[:, None] - local[None, :, 1])
        false += int(np.sum(gaps.min(axis=1, initial=np.inf) > 0.5))
        indices, spans = visible_poles(LASER, poles, pose, truth, hit, settings.segment_jump)
        for index in indices[spans >= settings.min_beams]:
            visible += 1
            distance = float(np.hypot(*local[index]))
            found += int(gaps[:, index].min(initial=np.inf) <= 0.03 + 0.01 * distance)
    assert visible > 100
    assert found >= 0.95 * visible
    assert false == 0


def test_evaluation_tallies_one_short_seed():
    tally = Tally()
    evaluate_seed(1, ExtractorSettings().validate(), tally, LASER, False, duration=10.0)
    assert tally.scans == 50 and tally.visible > 0
    assert tally.detected >= 0.9 * tally.visible


def test_evaluation_plot_is_written_once_without_overwrite(tmp_path, capsys):
    from fastslam_ros.tools.evaluation.extractor_eval import main
    figure = tmp_path / "scan.png"
    arguments = ["--seeds", "1", "--plot", str(figure), "--scan", "5"]
    assert main(arguments) == 0 and figure.stat().st_size > 1000
    assert main(arguments) == 2
    assert "scan.png" in capsys.readouterr().err
    assert main(["--set", "segment_jump=-1"]) == 2


def test_a_walking_person_paces_its_segment_and_hides_what_is_behind():
    """A person pacing (0, 5) -> (4, 5) at 1.2 m/s from its start: at 2.5 s it is 3 m along, at
    5 s 2 m along on its way back; the beam straight at it returns its body's front (radius
    0.2 m) as no pole, and at 0 s the beam at (3, 5) passes behind it to nothing."""
    world = PoleWorld(np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool), np.zeros((0, 4)),
                      np.array([[0.0, 5.0, 4.0, 5.0]]))
    np.testing.assert_allclose(world.walkers(2.5), [[3.0, 5.0]], atol=1e-12)
    np.testing.assert_allclose(world.walkers(5.0), [[2.0, 5.0]], atol=1e-12)
    pose = np.array([3.0, 0.0, 0.5 * math.pi])          # looking along +y at x = 3
    ranges, _, pole = LASER.cast(world, pose, 2.5)
    centre = LASER.beams // 2
    assert ranges[centre] == pytest.approx(4.8, abs=1e-9) and pole[centre] == -1
    assert np.isinf(LASER.cast(world, pose, 0.0)[0][centre])


def test_people_leave_the_pole_world_as_it_is_without_them():
    config = sim.SimConfig(seed=1).resolved()
    world = sim.build_world(config)
    plain = pole_world(config.world_seed, world.landmarks.positions, world.waypoints)
    crowded = pole_world(config.world_seed, world.landmarks.positions, world.waypoints, 10)
    np.testing.assert_array_equal(plain.walls, crowded.walls)
    np.testing.assert_array_equal(plain.radii, crowded.radii)
    assert len(plain.walks) == 0 and len(crowded.walks) == 10
