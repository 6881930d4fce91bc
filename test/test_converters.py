# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Dataset converters on the shared datasets (skipped when absent) and on a synthetic MRCLAM
folder in the 50 Hz resampled layout of the dataset's own tools."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fastslam_ros.tools.datasets import convert
from fastslam_ros.tools.datasets.converters import (freiburg, integrate_unicycle, mrclam,
                                                    victoria_park)

MRCLAM6 = "MRCLAM/MRCLAM_Dataset6"


def scan_at(recording, stamp: float) -> tuple[np.ndarray, np.ndarray]:
    """Points and ids of the scan stamped ``stamp``."""
    index = int(np.flatnonzero(np.isclose(recording.scan_stamps, stamp, atol=1e-6, rtol=0))[0])
    return recording.scan_points[index], recording.scan_ids[index]


def test_exact_arc_integration_matches_closed_form():
    stamps = np.linspace(0.0, 2.0, 9)
    poses = integrate_unicycle(stamps, np.full(9, 0.5), np.full(9, 0.8), np.array([1.0, 2.0, 0.3]))
    radius, heading = 0.5 / 0.8, 0.3 + 0.8 * stamps
    expected_x = 1.0 + radius * (np.sin(heading) - math.sin(0.3))
    expected_y = 2.0 - radius * (np.cos(heading) - math.cos(0.3))
    np.testing.assert_allclose(poses[:, 0], expected_x, atol=1e-12)
    np.testing.assert_allclose(poses[:, 1], expected_y, atol=1e-12)
    np.testing.assert_allclose(np.cos(poses[:, 2]), np.cos(heading), atol=1e-12)



def test_command_correction_fit_recovers_delay_and_gains():
    # Vicon moves with the commands 0.2 s late and at 0.9 (turn) / 0.95 (speed) of them.
    stamps = np.arange(0.0, 120.0, 0.02)
    speed = 0.2 + 0.1 * np.sin(0.7 * stamps)
    turn_rate = 0.4 * np.sin(0.9 * stamps) + 0.1
    commanded = integrate_unicycle(stamps, speed, turn_rate, np.zeros(3))
    truth = integrate_unicycle(stamps + 0.2, 0.95 * speed, 0.9 * turn_rate, np.zeros(3))
    fit = mrclam.fit_command_correction([(stamps, commanded, stamps + 0.2, truth)])
    assert fit["command_delay"] == pytest.approx(0.2)
    assert fit["yaw_rate_scale"] == pytest.approx(0.9, abs=1e-3)
    assert fit["speed_scale"] == pytest.approx(0.95, abs=1e-3)
    assert fit["heading_residual_corrected"] < 1e-3 < fit["heading_residual_raw"]

def test_mrclam_distributed_files(dataset_dir):
    folder = dataset_dir(MRCLAM6)
    recording = mrclam.load_mrclam(folder, robot=1, delay=0.0, speed_scale=1.0,
                                   yaw_rate_scale=1.0)
    counts = recording.counts
    assert counts["variant"] == "distributed"
    assert len(recording.odometry_stamps) == 61785
    assert counts["measurements_read"] == 1942
    assert counts["measurements_dropped_robot_barcodes"] == 407
    assert counts["measurements_dropped_unknown_barcodes"] == 1
    assert sum(len(ids) for ids in recording.scan_ids) == 1942 - 407 - 1
    assert len(recording.scan_stamps) == 1012

    # First odometry pose = Vicon pose interpolated at the first odometry time.
    truth = np.loadtxt(folder / "Robot1_Groundtruth.dat")
    first_time = np.loadtxt(folder / "Robot1_Odometry.dat")[0, 0]
    after = np.searchsorted(truth[:, 0], first_time)
    fraction = (first_time - truth[after - 1, 0]) / (truth[after, 0] - truth[after - 1, 0])
    expected = truth[after - 1, 1:] + fraction * (truth[after, 1:] - truth[after - 1, 1:])
    np.testing.assert_allclose(recording.odometry_poses[0], expected, atol=1e-9)

    # "1248444189.599  90  6.758  -0.005": barcode 90 is subject 15; barcode 14 (robot 2) dropped.
    points, ids = scan_at(recording, 1248444189.599)
    np.testing.assert_array_equal(ids, [15])
    np.testing.assert_allclose(points[0], [6.758 * math.cos(-0.005), 6.758 * math.sin(-0.005)])
    assert set(np.concatenate(recording.scan_ids)) <= set(range(6, 21))

    np.testing.assert_array_equal(recording.landmark_ids, np.arange(6, 21))
    np.testing.assert_allclose(recording.landmark_positions[0], [0.58831396, -4.28264845])
    assert counts["ground_truth_dropped_glitches"] == 0
    assert len(recording.ground_truth_stamps) == 49241

    unlabelled = mrclam.load_mrclam(folder, robot=1, use_ids=False)
    assert np.all(np.concatenate(unlabelled.scan_ids) == -1)


def test_mrclam_bag_round_trip(dataset_dir, tmp_path):
    from fastslam_ros.tools.bags.bag_schema import read_schema_bag

    folder = dataset_dir(MRCLAM6)
    written = convert.convert("mrclam", folder, tmp_path / "r3", robot=3, duration=60.0)
    bag = read_schema_bag(tmp_path / "r3")
    assert len(bag.odometry.stamps) == len(written.odometry_stamps)
    assert len(bag.scans.stamps) == len(written.scan_stamps) > 0
    np.testing.assert_allclose(bag.odometry.poses, written.odometry_poses, atol=1e-6)
    np.testing.assert_allclose(bag.ground_truth.poses[0], written.ground_truth_poses[0], atol=1e-6)
    np.testing.assert_allclose(bag.scans.points[0], written.scan_points[0], atol=1e-5)
    np.testing.assert_array_equal(bag.scans.ids[0], written.scan_ids[0])
    np.testing.assert_array_equal(np.sort(bag.landmarks_truth.ids), np.arange(6, 21))


def test_mrclam_calibration_is_fastslam_calibrates_on_the_converted_bag(dataset_dir, tmp_path):
    """``fastslam-convert mrclam --calibrate`` fits the robots it converts in memory with
    fastslam-calibrate's fit: the same figures as fastslam-calibrate on the bag written to
    disk (so the written bag holds what was fitted), and a command correction that lowers the
    heading residual."""
    from fastslam_ros.core.observation import SensorOffset
    from fastslam_ros.tools.bags.bag_schema import read_schema_bag
    from fastslam_ros.tools.evaluation.calibrate import calibrate_bags

    folder = dataset_dir(MRCLAM6)
    fit = mrclam.calibrate(folder, robots=(3,))
    convert.convert("mrclam", folder, tmp_path / "r3", robot=3)
    on_bag, _ = calibrate_bags([read_schema_bag(tmp_path / "r3")], SensorOffset())
    assert set(fit) == set(on_bag) | {"command_delay", "speed_scale", "yaw_rate_scale",
                                      "heading_residual_raw", "heading_residual_corrected"}
    for name, value in on_bag.items():  # the bag stores points as float32
        assert fit[name] == pytest.approx(value, rel=1e-5, abs=1e-9), name
    assert fit["heading_residual_corrected"] < fit["heading_residual_raw"]


def write_rows(path: Path, rows: list[list[float]]) -> None:
    path.write_text("".join(" ".join(f"{v:.6f}" for v in row) + "\n" for row in rows))


@pytest.fixture
def resampled_mrclam(tmp_path) -> Path:
    """A tiny MRCLAM folder as the 50 Hz sampling tools write it: times from 0, no headers,
    spaces, and rows before the common start with negative times."""
    write_rows(tmp_path / "Barcodes.dat", [[1, 5], [2, 14], [6, 63], [7, 81]])
    write_rows(tmp_path / "Landmark_Groundtruth.dat", [[6, 3.0, 1.0, 0.0, 0.0],
                                                       [7, 2.0, -2.0, 0.0, 0.0]])
    stamps = np.round(np.arange(-0.04, 2.0, 0.02), 2)
    write_rows(tmp_path / "Robot1_Odometry.dat", [[t, 0.1, 0.2] for t in stamps])
    write_rows(tmp_path / "Robot1_Groundtruth.dat",
               [[t, 0.5 + 0.1 * t, -0.2, 0.1 + 0.2 * t] for t in stamps])
    write_rows(tmp_path / "Robot1_Measurement.dat", [
        [-0.02, 63, 2.0, 0.1],   # before the start: dropped
        [0.50, 63, 2.5, 0.2], [0.50, 81, 3.0, -0.4],
        [0.50, 14, 1.0, 0.0],    # robot 2: dropped
        [1.00, 99, 1.0, 0.0],    # unknown barcode: dropped
        [1.20, 81, 2.9, -3.5],   # bearing to be wrapped
    ])
    return tmp_path


def test_mrclam_command_correction(resampled_mrclam):
    # Commands take effect `delay` later and are scaled: v = 0.05, omega = 0.1 here.
    recording = mrclam.load_mrclam(resampled_mrclam, robot=1, delay=0.2, speed_scale=0.5,
                                   yaw_rate_scale=0.5)
    assert recording.odometry_stamps[0] == 0.2
    start = np.array([0.5 + 0.02, -0.2, 0.1 + 0.04])        # ground truth at t = 0.2
    np.testing.assert_allclose(recording.odometry_poses[0], start, atol=1e-12)
    heading = start[2] + 0.1 * 1.98
    np.testing.assert_allclose(recording.odometry_poses[-1],
                               [start[0] + 0.5 * (math.sin(heading) - math.sin(start[2])),
                                start[1] - 0.5 * (math.cos(heading) - math.cos(start[2])),
                                heading], atol=1e-9)


def test_mrclam_resampled_variant(resampled_mrclam):
    recording = mrclam.load_mrclam(resampled_mrclam, robot=1, delay=0.0, speed_scale=1.0,
                                   yaw_rate_scale=1.0)
    counts = recording.counts
    assert counts["variant"] == "resampled"
    assert counts["odometry_dropped_negative_time"] == 2
    assert counts["ground_truth_dropped_negative_time"] == 2
    assert counts["measurements_dropped_negative_time"] == 1
    assert counts["measurements_dropped_robot_barcodes"] == 1
    assert counts["measurements_dropped_unknown_barcodes"] == 1
    assert recording.odometry_stamps[0] == 0.0
    np.testing.assert_allclose(recording.odometry_poses[0], [0.5, -0.2, 0.1], atol=1e-12)
    # v = 0.1, omega = 0.2 for 1.98 s: an exact arc of radius 0.5 from the start pose.
    heading = 0.1 + 0.2 * 1.98
    np.testing.assert_allclose(recording.odometry_poses[-1],
                               [0.5 + 0.5 * (math.sin(heading) - math.sin(0.1)),
                                -0.2 - 0.5 * (math.cos(heading) - math.cos(0.1)), heading],
                               atol=1e-9)
    np.testing.assert_allclose(recording.scan_stamps, [0.5, 1.2])
    points, ids = scan_at(recording, 0.5)
    np.testing.assert_array_equal(ids, [6, 7])
    np.testing.assert_allclose(points, [[2.5 * math.cos(0.2), 2.5 * math.sin(0.2)],
                                        [3.0 * math.cos(-0.4), 3.0 * math.sin(-0.4)]])
    points, ids = scan_at(recording, 1.2)
    np.testing.assert_allclose(points[0], [2.9 * math.cos(-3.5), 2.9 * math.sin(-3.5)])


def test_convert_cli_on_resampled_variant(resampled_mrclam, tmp_path, capsys):
    out = tmp_path / "out_bag"
    assert convert.main(["mrclam", str(resampled_mrclam), "--out", str(out), "--no-ids"]) == 0
    assert "measurements_dropped_unknown_barcodes: 1" in capsys.readouterr().out
    assert out.exists()
    assert convert.main(["mrclam", str(resampled_mrclam), "--out", str(out)]) == 2  # exists
    assert convert.main(["mrclam", str(tmp_path / "missing"), "--out", str(out)]) == 2


def test_victoria_park(dataset_dir):
    folder = dataset_dir("VictoriaPark")
    recording = victoria_park.load_victoria_park(folder)
    assert len(recording.odometry_stamps) == 61945
    assert len(recording.scan_stamps) == 7230
    assert sum(len(p) for p in recording.scan_points) == 52974
    # 4,466 GPS fixes, one of them an isolated jump 141 m off (1223.3 s) that is dropped.
    assert len(recording.ground_truth_stamps) == 4465 and recording.ground_truth_position_only
    assert recording.counts["gps_dropped_glitches"] == 1
    assert not np.any(np.isclose(recording.ground_truth_stamps, 1223.284, atol=1e-3))
    # GPS measures its antenna, at the front of the car, and the bag says so.
    assert recording.ground_truth_frame == "gps_antenna"
    assert recording.ground_truth_offset == victoria_park.GPS_ANTENNA
    assert np.all(np.concatenate(recording.scan_ids) == -1)
    np.testing.assert_array_equal(recording.odometry_poses[0], [0.0, 0.0, 0.0])

    # "0.852  20.46202  0.88575": laser bearing 0.88575 (0 = right) -> 0.88575 - pi/2.
    points, _ = scan_at(recording, 0.852)
    bearing = 0.88575 - math.pi / 2
    np.testing.assert_allclose(points[0], [20.46202 * math.cos(bearing),
                                           20.46202 * math.sin(bearing)], atol=1e-9)
    # The axle-centre path is about as long as the encoder's 4.03 km.
    steps = np.diff(recording.odometry_poses[:, :2], axis=0)
    assert 3.9e3 < np.hypot(steps[:, 0], steps[:, 1]).sum() < 4.2e3

    # Dead reckoning follows the GPS over the first two minutes after an SE(2) fit.
    gps_stamps, gps = recording.ground_truth_stamps, recording.ground_truth_poses[:, :2]
    early = gps_stamps < 120.0
    odometry = np.column_stack([np.interp(gps_stamps[early], recording.odometry_stamps,
                                          recording.odometry_poses[:, k]) for k in (0, 1)])
    errors = _aligned_errors(odometry, gps[early])
    assert np.sqrt(np.mean(errors**2)) < 3.0


def _aligned_errors(estimate: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Position errors after the least-squares rigid (rotation + translation) fit."""
    estimate_centred = estimate - estimate.mean(axis=0)
    reference_centred = reference - reference.mean(axis=0)
    u, _, vt = np.linalg.svd(estimate_centred.T @ reference_centred)
    rotation = (u @ vt).T
    if np.linalg.det(rotation) < 0:
        vt[-1] *= -1
        rotation = (u @ vt).T
    aligned = estimate_centred @ rotation.T + reference.mean(axis=0)
    return np.hypot(*(aligned - reference).T)


def test_victoria_park_gps_antenna_calibration_reproduces_the_shipped_value(dataset_dir):
    fit = victoria_park.calibrate(dataset_dir("VictoriaPark"))
    assert fit["windows"] >= 20
    assert fit["gps_antenna_x"] == pytest.approx(victoria_park.GPS_ANTENNA[0], abs=0.1)
    assert fit["gps_antenna_y"] == pytest.approx(victoria_park.GPS_ANTENNA[1], abs=0.1)


def test_victoria_park_gps_is_time_aligned(dataset_dir):
    assert abs(victoria_park.gps_time_lag(dataset_dir("VictoriaPark"))) <= 0.2


def test_freiburg(dataset_dir):
    recording = freiburg.load_freiburg(dataset_dir("FreiburgRobotMapping"))
    assert len(recording.odometry_stamps) == 332
    assert recording.odometry_stamps[1] - recording.odometry_stamps[0] == freiburg.STEP_DURATION
    assert sum(len(ids) for ids in recording.scan_ids) == 1212
    np.testing.assert_array_equal(recording.odometry_poses[0], [0.0, 0.0, 0.0])
    # First step "ODOMETRY 0.100692392654 0.100072845247 0.000171392857486".
    np.testing.assert_allclose(recording.odometry_poses[1],
                               [0.100072845247 * math.cos(0.100692392654),
                                0.100072845247 * math.sin(0.100692392654),
                                0.100692392654 + 0.000171392857486])
    # "SENSOR 2 3.85367751107 1.51951017943" follows the first step.
    points, ids = scan_at(recording, 1.0)
    np.testing.assert_array_equal(ids, [1, 2])
    np.testing.assert_allclose(points[1], [3.85367751107 * math.cos(1.51951017943),
                                           3.85367751107 * math.sin(1.51951017943)])
    bearings = np.arctan2(*np.concatenate(recording.scan_points)[:, ::-1].T)
    assert np.all(np.abs(bearings) <= math.pi)
    np.testing.assert_array_equal(recording.landmark_ids, np.arange(1, 10))
    np.testing.assert_allclose(recording.landmark_positions[6], [5.0, 5.0])
