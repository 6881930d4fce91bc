# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""fastslam-calibrate: the fit recovers the simulator's noise, reach and detection rate; the
sensor pose is used; the parameter file loads; bad paths give one-line errors."""
from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from fastslam_ros.core import FastSLAMConfig
from fastslam_ros.core.geometry import wrap_angle
from fastslam_ros.core.observation import SensorOffset
from fastslam_ros.tools.evaluation import calibrate, calibration_check
from fastslam_ros.tools.bags.bag_schema import PoseSeries, write_schema_bag
from fastslam_ros.tools.bags.replay import load_params_file
from fastslam_ros.tools.simulation.sim import SimConfig, simulate

SIGMA_RANGE, SIGMA_BEARING = 0.2, 0.03


@pytest.fixture(scope="module")
def loop_bags():
    """Two noise seeds of the loop scenario with a noisier sensor than the default."""
    return [simulate(SimConfig(seed=seed, world_seed=seed, sigma_range=SIGMA_RANGE,
                               sigma_bearing=SIGMA_BEARING)) for seed in (1, 2)]


def range_sigma(params: dict, at: float) -> float:
    return math.hypot(params["sigma_range"], params["sigma_range_per_meter"] * at)


def test_sensor_noise_and_reach_of_the_simulator_are_recovered(loop_bags):
    params, figures = calibrate.calibrate_bags(loop_bags, SensorOffset(), step=0.5)
    # About 17,000 residuals: the robust std is within 1.5 % (1 sigma) of the truth.
    for at in (5.0, 15.0, 25.0):
        assert range_sigma(params, at) == pytest.approx(SIGMA_RANGE, rel=0.06)
    assert params["sigma_bearing"] == pytest.approx(SIGMA_BEARING, rel=0.05)
    assert params["outlier_probability"] < 0.005            # Gaussian noise: no outliers
    assert params["max_range"] == pytest.approx(30.0, abs=0.5)
    assert params["field_of_view"] == pytest.approx(2 * math.pi)
    assert figures["detection_probability"] > 0.99 and figures["clutter_rate"] == 0.0


def test_odometry_noise_matches_the_simulators_closed_form(loop_bags):
    """Per control step the simulator perturbs the speed (sigma_speed) and the steering
    (sigma_steer) independently: over a straight metre the heading variance is
    v dt sigma_steer^2 / L^2 and the along-track variance sigma_speed^2 dt / v."""
    config = SimConfig()
    dt = 1.0 / config.control_rate
    heading_per_meter = config.speed * dt * config.sigma_steer ** 2 / config.wheelbase ** 2
    along_per_meter = config.sigma_speed ** 2 * dt / config.speed
    params, _ = calibrate.calibrate_bags(loop_bags, SensorOffset(), step=0.5)
    assert params["rotation_variance_per_meter"] == pytest.approx(heading_per_meter, rel=0.25)
    assert params["translation_variance_per_meter"] == pytest.approx(along_per_meter, rel=0.25)


def test_increments_of_a_reading_interval_stay_inside_the_recording():
    # At epoch stamps (1.7e9 s) np.arange's last point rounds past the last stamp for this
    # bag and step; every increment must still lie inside the time both series cover.
    bag = simulate(SimConfig())
    assert bag.odometry.stamps[-1] - bag.odometry.stamps[0] == pytest.approx(209.4)
    odometry_steps, true_steps, walk = calibrate.odometry_rows(bag, 0.2, 1.0)
    # Grid points at 0, 0.2, ..., 209.2 s (the end, 209.4 s, excluded): 1,046 increments.
    assert len(odometry_steps) == len(true_steps) == len(walk) == 1046


def test_detection_probability_clutter_and_a_narrow_sensor():
    bag = simulate(SimConfig(scenario="clutter", seed=3, world_seed=3, max_range=20.0))
    # Keep only what a +-0.8 rad sensor sees.
    for index, points in enumerate(bag.scans.points):
        keep = np.abs(np.arctan2(points[:, 1], points[:, 0])) <= 0.8
        bag.scans.points[index], bag.scans.ids[index] = points[keep], bag.scans.ids[index][keep]
    params, figures = calibrate.calibrate_bags([bag], SensorOffset())
    assert params["max_range"] == pytest.approx(20.0, abs=0.3)
    assert params["field_of_view"] == pytest.approx(1.6, abs=0.03)
    assert figures["detection_probability"] == pytest.approx(0.9, abs=0.015)
    # The simulator labels its false detections -1; a few fall within the match radius of a
    # landmark and count as detections of it.
    false_per_reading = np.mean([np.count_nonzero(ids < 0) for ids in bag.scans.ids])
    assert false_per_reading == pytest.approx(2.0 * 1.6 / (2 * math.pi), rel=0.15)
    assert 0.85 * false_per_reading <= figures["clutter_rate"] <= false_per_reading


def test_the_sensor_pose_is_used():
    """The same detections expressed in a sensor frame 0.5 m ahead, 0.2 m left and turned by
    0.3 rad: fitted with that pose they give the simulator's noise, without it far more."""
    bag = simulate(SimConfig(seed=4, world_seed=4, duration=60.0))
    offset = SensorOffset(0.5, 0.2, 0.3)
    moved = []
    for points in bag.scans.points:
        shifted = points.astype(float) - (offset.x, offset.y)
        c, s = math.cos(offset.yaw), math.sin(offset.yaw)
        moved.append(np.column_stack((c * shifted[:, 0] + s * shifted[:, 1],
                                      -s * shifted[:, 0] + c * shifted[:, 1])))
    bag = dataclasses.replace(bag, scans=dataclasses.replace(bag.scans, points=moved))
    right, right_figures = calibrate.calibrate_bags([bag], offset)
    wrong, wrong_figures = calibrate.calibrate_bags([bag], SensorOffset())
    assert range_sigma(right, 15.0) == pytest.approx(0.1, rel=0.1)
    assert right["sigma_bearing"] == pytest.approx(math.radians(1.0), rel=0.1)
    assert abs(right_figures["bearing_bias"]) < 0.002 and abs(right_figures["range_bias"]) < 0.01
    # Without the pose: the bearings are off by the sensor's yaw, and the lever arm spreads
    # the residuals.
    assert wrong_figures["bearing_bias"] == pytest.approx(-offset.yaw, abs=0.03)
    assert wrong["sigma_bearing"] > 1.5 * right["sigma_bearing"]
    assert range_sigma(wrong, 15.0) > 2.0 * range_sigma(right, 15.0)


def test_readings_inside_a_ground_truth_gap_are_left_out():
    """3.4 s of ground truth cut out between two readings: the readings strictly inside the
    gap are left out, those on the truth's stamps at its ends are kept (nothing to
    interpolate there)."""
    bag = simulate(SimConfig(seed=6, world_seed=6, duration=30.0))
    truth, scans = bag.ground_truth, np.asarray(bag.scans.stamps)
    before, after = scans[50], scans[67]
    assert np.isin([before, after], truth.stamps).all()
    cut = (truth.stamps > before) & (truth.stamps < after)
    gappy = dataclasses.replace(bag, ground_truth=dataclasses.replace(
        truth, stamps=truth.stamps[~cut], poses=truth.poses[~cut]))
    inside = int(np.count_nonzero((scans > before) & (scans < after)))
    _, whole = calibrate.calibrate_bags([bag], SensorOffset())
    _, figures = calibrate.calibrate_bags([gappy], SensorOffset())
    assert whole["readings_without_truth"] == 0 and inside == 16
    assert figures["readings_without_truth"] == inside
    assert figures["readings"] == whole["readings"] - inside


def test_residuals_against_an_exact_reading():
    """One reading built by hand: residuals are measured minus predicted range and bearing."""
    truth = calibrate.Reading(np.array([1.0, 2.0, 0.5]), np.array([[3.0, 0.0]]),
                              np.array([0]), np.array([[1.0 + 3.1 * math.cos(0.6),
                                                         2.0 + 3.1 * math.sin(0.6)]]))
    found = calibrate.residuals([truth])
    np.testing.assert_allclose(found.range_error, [3.0 - 3.1], atol=1e-12)
    np.testing.assert_allclose(found.bearing_error, [wrap_angle(0.0 - 0.1)], atol=1e-12)


def test_command_line_writes_a_loadable_parameter_file(tmp_path, capsys):
    bag = write_schema_bag(tmp_path / "sim", simulate(SimConfig(seed=5, world_seed=5,
                                                                duration=60.0)))
    base = tmp_path / "base.yaml"
    base.write_text("/**:\n  ros__parameters:\n    num_particles: 30\n    sensor_x: 0.0\n"
                    "    alpha1: 0.2\n")
    out = tmp_path / "calibrated.yaml"
    assert calibrate.main([str(bag), "--params", str(base), "--out", str(out),
                           "--no-validate"]) == 0
    printed = capsys.readouterr().out
    assert "sigma_range:" in printed and "detection_probability" in printed
    values = load_params_file(out)
    assert values["num_particles"] == 30                  # copied from --params
    assert values["alpha1"] == 0.0                        # random-walk model: alphas off
    assert values["rotation_variance_per_meter"] > 0.0
    assert values["sigma_bearing"] == pytest.approx(math.radians(1.0), rel=0.1)
    core = {name: value for name, value in values.items()
            if name in FastSLAMConfig.__dataclass_fields__}
    FastSLAMConfig(**core).validate()
    # An existing output is kept without --overwrite and replaced with it.
    assert calibrate.main([str(bag), "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert calibrate.main([str(bag), "--out", str(out), "--overwrite",
                           "--motion-model", "alphas", "--no-validate"]) == 0
    values = load_params_file(out)
    assert values["rotation_variance_per_meter"] == 0.0 and "num_particles" not in values
    # Never its own input, not even with --overwrite.
    before = base.read_bytes()
    assert calibrate.main([str(bag), "--params", str(base), "--out", str(base),
                           "--overwrite"]) == 2
    assert base.read_bytes() == before and "input" in capsys.readouterr().err


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert err.startswith("fastslam-calibrate: ") and "\n" not in err
    return err


def test_bad_paths_and_bags_give_one_line_errors(tmp_path, capsys):
    assert calibrate.main([str(tmp_path / "missing")]) == 2
    assert "not found" in one_line_error(capsys)
    bag = simulate(SimConfig(duration=10.0))
    no_truth = write_schema_bag(tmp_path / "no_truth",
                                dataclasses.replace(bag, ground_truth=None))
    assert calibrate.main([str(no_truth)]) == 1
    assert "ground_truth" in one_line_error(capsys)
    gps = dataclasses.replace(bag, ground_truth=PoseSeries(
        bag.ground_truth.stamps, bag.ground_truth.poses, "map", position_only=True))
    assert calibrate.main([str(write_schema_bag(tmp_path / "gps", gps))]) == 1
    assert "position only" in one_line_error(capsys)
    good = write_schema_bag(tmp_path / "good", bag)
    assert calibrate.main([str(good), "--out", str(tmp_path / "no" / "dir.yaml")]) == 2
    assert "does not exist" in one_line_error(capsys)
    assert calibrate.main([str(good), "--params", str(tmp_path / "nothing.yaml")]) == 2
    one_line_error(capsys)
    (tmp_path / "bad.yaml").write_text("[1, 2")
    assert calibrate.main([str(good), "--params", str(tmp_path / "bad.yaml")]) == 2
    one_line_error(capsys)


def test_help(capsys):
    with pytest.raises(SystemExit) as exit_info:
        calibrate.main(["--help"])
    assert exit_info.value.code == 0
    printed = capsys.readouterr().out
    assert "usage: fastslam-calibrate" in printed and "``" not in printed


def test_the_fit_sees_only_the_first_half_of_every_stream():
    bag = simulate(SimConfig(seed=2, duration=40.0))
    first = calibration_check.first_part(bag)
    cut = bag.odometry.stamps[0] + 0.5 * (bag.odometry.stamps[-1] - bag.odometry.stamps[0])
    for whole, early in ((bag.odometry, first.odometry), (bag.ground_truth, first.ground_truth)):
        before = whole.stamps < cut
        assert early.stamps.max() < cut and 0 < before.sum() < len(whole.stamps)
        np.testing.assert_array_equal(early.stamps, whole.stamps[before])
        np.testing.assert_array_equal(early.poses, whole.poses[before])
    before = np.flatnonzero(bag.scans.stamps < cut)
    np.testing.assert_array_equal(first.scans.stamps, bag.scans.stamps[before])
    for points, ids, index in zip(first.scans.points, first.scans.ids, before):
        np.testing.assert_array_equal(points, bag.scans.points[index])
        np.testing.assert_array_equal(ids, bag.scans.ids[index])


@pytest.mark.parametrize("start, fitted, status", [
    ((0.10, 0.12), (0.20, 0.22), 1),      # worse everywhere
    ((0.20, 0.30), (0.10, 0.20), 0),      # better everywhere
    ((0.10, 0.12), (0.101, 0.121), 0),    # within the tolerance
    ((0.20, 0.30), (0.10, 0.40), 1),      # a better mean, a worse worst replay
])
def test_a_fit_that_does_worse_on_the_replays_is_not_written(tmp_path, capsys, monkeypatch,
                                                              start, fitted, status):
    """The verdict decides: the replays' ATEs with the starting parameters, then with the fit
    (here given), and the file is written only when the fit's mean and worst are no worse
    (within the tolerance)."""
    bag = write_schema_bag(tmp_path / "sim", simulate(SimConfig(seed=5, duration=30.0)))
    scores = iter([np.array(start), np.array(fitted)])
    monkeypatch.setattr(calibration_check, "replay_ates", lambda bags, params: next(scores))
    out = tmp_path / "fit.yaml"
    assert calibrate.main([str(bag), "--out", str(out)]) == status
    captured = capsys.readouterr()
    assert out.exists() == (status == 0)
    assert (f"{np.mean(start):.4g} / {max(start):.4g} m starting parameters, "
            f"{np.mean(fitted):.4g} / {max(fitted):.4g} m fitted") in captured.out
    if status:
        assert "not written" in captured.err and len(captured.err.strip().splitlines()) == 1


def test_the_check_replays_every_bag_whole_for_every_seed(tmp_path, capsys):
    """End to end on a short simulated bag: the starting parameters' scores are those of the
    whole bag replayed with each validation seed (a replay is deterministic), and the file
    exists exactly when the fit is kept."""
    bag = write_schema_bag(tmp_path / "sim", simulate(SimConfig(seed=5, duration=60.0)))
    out = tmp_path / "fit.yaml"
    status = calibrate.main([str(bag), "--out", str(out)])
    printed = capsys.readouterr().out
    found = re.search(r"([0-9.e-]+) / ([0-9.e-]+) m starting parameters, ([0-9.e-]+) / "
                      r"([0-9.e-]+) m fitted", printed)
    start, start_worst, fitted, fitted_worst = map(float, found.groups())
    whole = calibration_check.replay_ates([bag], {})
    assert len(whole) == len(calibration_check.VALIDATION_SEEDS)
    assert f"{start:.4g} / {start_worst:.4g}" == calibration_check.Verdict.summary(whole)
    assert 0.0 < fitted <= fitted_worst
    keeps = (fitted <= calibration_check.TOLERANCE * start
             and fitted_worst <= calibration_check.TOLERANCE * start_worst)
    assert (status == 0) == keeps == out.exists()

