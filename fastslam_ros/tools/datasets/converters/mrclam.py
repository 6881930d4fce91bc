# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""UTIAS MRCLAM (multi-robot cooperative localization and mapping) -> one robot's recording.

Two layouts of the same files are read, detected from the time stamps:

* ``distributed``: the files as released (Unix-epoch times, ``#`` headers, CRLF, tabs);
* ``resampled``: the output of the dataset's own 50 Hz sampling tools (times from 0, no
  headers, spaces); rows with a negative time (before the common start) are dropped.

Odometry poses integrate the logged (v, omega) commands with exact arcs, starting at the
ground-truth pose at the first odometry time, so the map and odom frames coincide at the start.
Each measurement time becomes one scan of points x = r cos(b), y = r sin(b) in the robot frame,
labelled with the landmark's subject id (barcode -> subject through ``Barcodes.dat``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fastslam_ros.core.geometry import wrap_angle
from fastslam_ros.core.observation import SensorOffset
from fastslam_ros.node_support.timing import interpolate_poses
from fastslam_ros.tools.evaluation.calibrate import calibrate_bags
from fastslam_ros.tools.datasets.converters import (Recording, group_by_stamp, integrate_unicycle,
                                           isolated_jumps, polar_to_points, read_table)

EPOCH_THRESHOLD = 1.0e8
"""Stamps above this (s) are Unix-epoch times of the distributed files."""
GLITCH_WINDOW = 7
"""Samples in the running median that Vicon glitches are detected against."""
GLITCH_POSITION = 0.10
"""A ground-truth sample farther than this (m) from its running median is a glitch."""
GLITCH_HEADING = 0.30
"""Same bound for the heading (rad)."""
COMMAND_DELAY = 0.2
"""Seconds between a logged (v, omega) command and the motion it causes (drive latency).
``calibrate`` on the five robots of Dataset 6 (``command_delay``) finds the 1 s heading changes
of the integrated commands closest to Vicon's 0.25 s later (RMS 0.0246 rad, 0.0422 rad
uncorrected); the optimum is flat, and 0.2 s is kept."""
SPEED_SCALE = 0.93
"""Actual over commanded forward speed (``calibrate``: ``speed_scale`` 0.930 on Dataset 6): the
robots drive slower than commanded."""
YAW_RATE_SCALE = 0.93
"""Actual over commanded turn rate (``calibrate``: ``yaw_rate_scale`` 0.929 on Dataset 6)."""


def detect_variant(folder: Path | str, robot: int) -> str:
    """``"distributed"`` (epoch times) or ``"resampled"`` (times from 0) for this robot's files."""
    odometry = read_table(Path(folder) / f"Robot{robot}_Odometry.dat", 3)
    return "distributed" if odometry[0, 0] > EPOCH_THRESHOLD else "resampled"


def _read_timed(path: Path, columns: int) -> tuple[np.ndarray, int]:
    """Rows of a time-stamped file sorted by time, without negative times; and the dropped count."""
    table = read_table(path, columns)
    keep = table[:, 0] >= 0.0
    table = table[keep]
    return table[np.argsort(table[:, 0], kind="stable")], int(np.count_nonzero(~keep))


def load_barcodes(folder: Path | str) -> dict[int, int]:
    """Barcode number -> subject id."""
    table = read_table(Path(folder) / "Barcodes.dat", 2).astype(int)
    return {int(barcode): int(subject) for subject, barcode in table}


def load_landmarks(folder: Path | str) -> tuple[np.ndarray, np.ndarray]:
    """Landmark truth: positions (L, 2) in the Vicon (map) frame and subject ids (L,)."""
    table = read_table(Path(folder) / "Landmark_Groundtruth.dat", 3)
    return table[:, 1:3].copy(), table[:, 0].astype(np.int32)


def remove_vicon_glitches(poses: np.ndarray) -> np.ndarray:
    """Boolean mask of the ground-truth samples to keep (isolated jumps removed).

    A sample is a glitch when its position or heading is far from the running median of its
    neighbours: a real motion moves the median with it, an isolated jump does not.
    """
    from scipy.ndimage import median_filter

    size = min(GLITCH_WINDOW, len(poses)) | 1
    cos_median = median_filter(np.cos(poses[:, 2]), size=size, mode="nearest")
    sin_median = median_filter(np.sin(poses[:, 2]), size=size, mode="nearest")
    heading_error = np.abs(wrap_angle(poses[:, 2] - np.arctan2(sin_median, cos_median)))
    return (~isolated_jumps(poses[:, :2], GLITCH_WINDOW, GLITCH_POSITION)
            & (heading_error <= GLITCH_HEADING))


def load_ground_truth(folder: Path | str, robot: int
                      ) -> tuple[np.ndarray, np.ndarray, dict[str, int]]:
    """Vicon poses of one robot without glitches: stamps (T,), poses (T, 3), dropped counts."""
    table, negative = _read_timed(Path(folder) / f"Robot{robot}_Groundtruth.dat", 4)
    keep = remove_vicon_glitches(table[:, 1:4])
    poses = table[keep, 1:4]
    poses[:, 2] = wrap_angle(poses[:, 2])
    counts = {"ground_truth_dropped_negative_time": negative,
              "ground_truth_dropped_glitches": int(np.count_nonzero(~keep))}
    return table[keep, 0], poses, counts


def load_odometry(folder: Path | str, robot: int, start_pose: np.ndarray | None = None,
                  ground_truth: tuple[np.ndarray, np.ndarray] | None = None,
                  delay: float = COMMAND_DELAY, speed_scale: float = SPEED_SCALE,
                  yaw_rate_scale: float = YAW_RATE_SCALE
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Odometry of one robot: stamps (N,), integrated poses (N, 3), commands (N, 2), negatives
    dropped.

    The logged commands are scaled by ``speed_scale`` / ``yaw_rate_scale`` and take effect
    ``delay`` seconds after their stamp (the returned stamps are shifted by it). The integration
    starts at ``start_pose``, else at the ground truth interpolated at the first (shifted)
    odometry time, else at the origin.
    """
    table, negative = _read_timed(Path(folder) / f"Robot{robot}_Odometry.dat", 3)
    stamps = table[:, 0] + delay
    commands = table[:, 1:3] * np.array([speed_scale, yaw_rate_scale])
    if start_pose is None:
        start_pose = (interpolate_poses(*ground_truth, stamps[:1])[0] if ground_truth is not None
                      else np.zeros(3))
    poses = integrate_unicycle(stamps, commands[:, 0], commands[:, 1],
                               np.asarray(start_pose, float))
    return stamps, poses, commands, negative


def load_measurements(folder: Path | str, robot: int
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, int]]:
    """Landmark measurements of one robot: stamps, subject ids, ranges, bearings, dropped counts.

    Barcodes of robots and barcodes absent from ``Barcodes.dat`` are dropped and counted.
    """
    folder = Path(folder)
    table, negative = _read_timed(folder / f"Robot{robot}_Measurement.dat", 4)
    barcode_to_subject = load_barcodes(folder)
    _, landmark_subjects = load_landmarks(folder)
    barcodes = table[:, 1].astype(int)
    subjects = np.array([barcode_to_subject.get(b, -1) for b in np.unique(barcodes)])
    subject_of_row = subjects[np.searchsorted(np.unique(barcodes), barcodes)]
    known = subject_of_row >= 0
    is_landmark = np.isin(subject_of_row, landmark_subjects)
    counts = {"measurements_read": int(len(table) + negative),
              "measurements_dropped_negative_time": negative,
              "measurements_dropped_robot_barcodes": int(np.count_nonzero(known & ~is_landmark)),
              "measurements_dropped_unknown_barcodes": int(np.count_nonzero(~known))}
    rows = table[is_landmark]
    return (rows[:, 0], subject_of_row[is_landmark].astype(np.int32), rows[:, 2],
            wrap_angle(rows[:, 3]), counts)


def load_mrclam(folder: Path | str, robot: int, use_ids: bool = True,
                delay: float = COMMAND_DELAY, speed_scale: float = SPEED_SCALE,
                yaw_rate_scale: float = YAW_RATE_SCALE) -> Recording:
    """Convert one robot of an MRCLAM dataset folder (either variant) to a :class:`Recording`
    (odometry commands corrected as in :func:`load_odometry`)."""
    folder = Path(folder)
    gt_stamps, gt_poses, counts = load_ground_truth(folder, robot)
    odom_stamps, odom_poses, _, negative = load_odometry(folder, robot,
                                                         ground_truth=(gt_stamps, gt_poses),
                                                         delay=delay, speed_scale=speed_scale,
                                                         yaw_rate_scale=yaw_rate_scale)
    meas_stamps, subjects, ranges, bearings, meas_counts = load_measurements(folder, robot)
    labels = subjects if use_ids else np.full_like(subjects, -1)
    scan_stamps, scan_points, scan_ids = group_by_stamp(
        meas_stamps, polar_to_points(ranges, bearings), labels)
    landmark_positions, landmark_ids = load_landmarks(folder)
    counts = {"variant": detect_variant(folder, robot),
              "odometry_dropped_negative_time": negative, **counts, **meas_counts}
    return Recording(odom_stamps, odom_poses, scan_stamps, scan_points, scan_ids,
                     gt_stamps, gt_poses, False, landmark_positions, landmark_ids, counts)


def calibrate(folder: Path | str, robots: tuple[int, ...] = (1, 2, 3, 4, 5),
              step: float = 1.0) -> dict[str, float]:
    """Parameters of the MRCLAM setup, estimated against the Vicon ground truth of ``robots``.

    * command_delay, speed_scale, yaw_rate_scale: the correction of the logged commands
      (:func:`fit_command_correction` on the raw commands, ``step`` windows).
    * The noise, reach and odometry fits of ``fastslam-calibrate``
      (``calibrate.calibrate_bags``) on the robots' recordings as converted (commands
      corrected with the defaults, camera at the base), as it gives on the converted bags.
    """
    folder = Path(folder)
    command_rows = []
    for robot in robots:
        gt_stamps, gt_poses, _ = load_ground_truth(folder, robot)
        raw_stamps, raw_poses, _, _ = load_odometry(folder, robot, start_pose=np.zeros(3),
                                                    delay=0.0, speed_scale=1.0,
                                                    yaw_rate_scale=1.0)
        command_rows.append((raw_stamps, raw_poses, gt_stamps, gt_poses))
    bags = [load_mrclam(folder, robot).to_schema_bag() for robot in robots]
    params, _ = calibrate_bags(bags, SensorOffset(), step)
    return {**fit_command_correction(command_rows, step), **params}


def fit_command_correction(runs: list, step: float = 1.0,
                           delays: np.ndarray = np.arange(0.0, 0.45, 0.05)) -> dict[str, float]:
    """Drive latency and gains of the logged commands against the Vicon ground truth.

    ``runs``: (odometry stamps, poses integrated from the raw commands, ground-truth stamps,
    poses) per robot. For each candidate delay, the heading changes and distances of ``step``
    windows of the odometry, taken ``delay`` earlier, are regressed (through the origin) on the
    ground truth's, pooled over the robots; the delay with the smallest heading residual wins.
    Returns command_delay, yaw_rate_scale, speed_scale and the heading residual RMS with and
    without the correction.
    """
    def fit(delay: float) -> tuple[float, float, float, float]:
        turn_true, turn_odom, dist_true, dist_odom = _window_changes(runs, delay, step)
        keep = np.abs(turn_true - turn_odom) < 0.5          # Vicon dropouts, collisions
        turn_true, turn_odom = turn_true[keep], turn_odom[keep]
        dist_true, dist_odom = dist_true[keep], dist_odom[keep]
        yaw_scale = float(turn_true @ turn_odom / (turn_odom @ turn_odom))
        speed_scale = float(dist_true @ dist_odom / (dist_odom @ dist_odom))
        residual = float(np.sqrt(np.mean((turn_true - yaw_scale * turn_odom) ** 2)))
        raw = float(np.sqrt(np.mean((turn_true - turn_odom) ** 2)))
        return residual, yaw_scale, speed_scale, raw

    fits = {float(delay): fit(float(delay)) for delay in delays}
    delay = min(fits, key=lambda candidate: fits[candidate][0])
    residual, yaw_scale, speed_scale, _ = fits[delay]
    uncorrected = fits[0.0] if 0.0 in fits else fit(0.0)
    return {"command_delay": delay, "yaw_rate_scale": yaw_scale, "speed_scale": speed_scale,
            "heading_residual_raw": uncorrected[3], "heading_residual_corrected": residual}


def _window_changes(runs: list, delay: float, step: float):
    """Heading changes and distances over ``step`` windows of the ground truth and of the
    odometry taken ``delay`` earlier, pooled over the runs: (turn_true, turn_odom, dist_true,
    dist_odom)."""
    changes = [[], [], [], []]
    for odom_stamps, odom_poses, gt_stamps, gt_poses in runs:
        grid = np.arange(max(odom_stamps[0] + delay, gt_stamps[0]) + step,
                         min(odom_stamps[-1] + delay, gt_stamps[-1]) - step, step)
        for target, (stamps, poses, at) in enumerate(((gt_stamps, gt_poses, grid),
                                                      (odom_stamps, odom_poses, grid - delay))):
            sampled = interpolate_poses(stamps, poses, at)
            changes[target].append(wrap_angle(np.diff(sampled[:, 2])))
            changes[target + 2].append(np.hypot(*np.diff(sampled[:, :2], axis=0).T))
    return tuple(np.concatenate(values) for values in changes)
