# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""ACFR Victoria Park (``rfs_slam_txt`` files of RFS-SLAM) -> recording of the car.

* Odometry: the rear-left wheel encoder speed is moved to the rear-axle centre,
  v_c = v_e / (1 - tan(steering) H / L), and the rear-axle-centre pose is integrated with the
  bicycle (Ackermann) model: x' = v_c cos(theta), y' = v_c sin(theta),
  theta' = v_c tan(steering) / L, exactly over each 25 ms step (arcs).
* Tree detections: the laser's bearing runs 0..pi from the vehicle's right to its left, so the
  bearing in the laser frame (x forward, y left) is ``bearing - pi/2``. Points are written in
  the laser frame; its position on the vehicle (a forward, b left of the rear-axle centre) is the
  node's ``sensor_x``/``sensor_y`` (``config/victoria_park.yaml``). No ids (-1).
* Ground truth: GPS positions (``gps.dat``, in RFS-SLAM's start-aligned frame), position-only.
  All three files share one clock (0 = first GPS fix, 20.967 s of the original ACFR clock).
  The failing unit also jumps: a fix farther than ``GPS_GLITCH`` from the running median of its
  neighbours is dropped (one fix, 141 m off at 1223.3 s; the few-metre jitter stays), so that a
  single bad reference fix does not dominate an RMSE. The antenna is not on the rear axle:
  ``calibrate`` fits its position on the car from dead reckoning against GPS over short windows
  (``GPS_ANTENNA``); the bag carries it as the static transform ``base_link`` ->
  ``gps_antenna``, and the evaluation compares the estimated antenna position with GPS.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fastslam_ros.core.geometry import wrap_angle
from fastslam_ros.node_support.timing import interpolate_poses
from fastslam_ros.tools.datasets.converters import (Recording, group_by_stamp, integrate_unicycle,
                                           isolated_jumps, polar_to_points, read_table)

WHEELBASE = 2.83
"""L: distance between the axles (m)."""
ENCODER_OFFSET = 0.76
"""H: lateral distance from the rear-axle centre to the rear-left wheel encoder (m)."""
LASER_FORWARD = 3.78
"""a: laser position ahead of the rear axle (m)."""
LASER_LEFT = 0.50
"""b: laser position left of the vehicle's centre line (m), the sign of RFS-SLAM's and ACFR's
kinematics (x_L = x + a cos(theta) - b sin(theta), y_L = y + a sin(theta) + b cos(theta))."""
GPS_ANTENNA = (3.7, 1.0)
"""Position (x forward, y left; m) of the GPS antenna relative to the rear-axle centre, from
``fastslam-convert victoria-park ../shared/datasets/VictoriaPark --calibrate``: (3.69, 1.01)
with 30 s windows; 20-40 s windows give 3.5-4.0 m forward and 0.8-1.1 m left. The antenna
is at the front of the car, by the laser (3.78, 0.50). Ignoring it compares the rear axle
with a point ~3.8 m ahead of it, a heading-dependent error the SE(2) alignment cannot
remove."""
ANTENNA_WINDOW = 30.0
"""Length (s) of the dead-reckoning windows that the antenna position is fitted over."""
GPS_GLITCH_WINDOW = 5
"""Fixes in the running median that GPS jumps are detected against."""
GPS_GLITCH = 20.0
"""A fix farther than this (m) from its running median is a glitch: beyond the GPS jitter
(consecutive fixes 0.2 s apart differ by up to ~5 m) and the car's motion across a gap."""


def axle_centre_speed(encoder_speed: np.ndarray, steering: np.ndarray) -> np.ndarray:
    """Speed of the rear-axle centre from the rear-left wheel encoder speed (m/s)."""
    return encoder_speed / (1.0 - np.tan(steering) * ENCODER_OFFSET / WHEELBASE)


def load_odometry(folder: Path | str, start_pose: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Stamps (N,) and rear-axle-centre poses (N, 3) integrated from ``inputs.dat``."""
    table = read_table(Path(folder) / "inputs.dat", 3)
    stamps, encoder_speed, steering = table.T
    speed = axle_centre_speed(encoder_speed, steering)
    yaw_rate = speed * np.tan(steering) / WHEELBASE
    start = np.zeros(3) if start_pose is None else np.asarray(start_pose, float)
    return stamps, integrate_unicycle(stamps, speed, yaw_rate, start)


def load_detections(folder: Path | str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Tree detections: stamps, ranges (m), laser-frame bearings (rad, 0 = ahead), diameters (m)."""
    table = read_table(Path(folder) / "measurements.dat", 4)
    table = table[np.argsort(table[:, 0], kind="stable")]
    return table[:, 0], table[:, 1], wrap_angle(table[:, 2] - np.pi / 2.0), table[:, 3]


def load_gps(folder: Path | str) -> tuple[np.ndarray, np.ndarray, int]:
    """GPS stamps (G,) and positions (G, 2) (m) without isolated jumps; the dropped count."""
    table = read_table(Path(folder) / "gps.dat", 3)
    glitch = isolated_jumps(table[:, 1:3], GPS_GLITCH_WINDOW, GPS_GLITCH)
    return table[~glitch, 0], table[~glitch, 1:3].copy(), int(np.count_nonzero(glitch))


def load_victoria_park(folder: Path | str) -> Recording:
    """Convert the ``rfs_slam_txt`` folder (or the dataset folder holding it) to a Recording."""
    folder = Path(folder)
    if (folder / "rfs_slam_txt").is_dir():
        folder = folder / "rfs_slam_txt"
    odom_stamps, odom_poses = load_odometry(folder)
    stamps, ranges, bearings, _ = load_detections(folder)
    labels = np.full(len(stamps), -1, dtype=np.int32)
    scan_stamps, scan_points, scan_ids = group_by_stamp(stamps, polar_to_points(ranges, bearings),
                                                        labels)
    gps_stamps, gps_positions, glitches = load_gps(folder)
    ground_truth = np.column_stack((gps_positions, np.zeros(len(gps_stamps))))
    counts = {"detections": len(stamps), "gps_fixes": len(gps_stamps),
              "gps_dropped_glitches": glitches}
    return Recording(odom_stamps, odom_poses, scan_stamps, scan_points, scan_ids,
                     gps_stamps, ground_truth, True, None, None, counts,
                     ground_truth_frame="gps_antenna", ground_truth_offset=GPS_ANTENNA)


def gps_time_lag(folder: Path | str, lags: np.ndarray = np.arange(-2.0, 2.001, 0.05)) -> float:
    """Lag (s) of the GPS behind the odometry that best matches their speeds.

    GPS speed (from fixes 0.2 s apart, jumps removed) is compared with the odometry speed
    shifted by each candidate lag; the lag with the least median absolute difference wins.
    """
    folder = Path(folder)
    if (folder / "rfs_slam_txt").is_dir():
        folder = folder / "rfs_slam_txt"
    table = read_table(folder / "inputs.dat", 3)
    speed = np.abs(axle_centre_speed(table[:, 1], table[:, 2]))
    gps_stamps, gps_positions, _ = load_gps(folder)
    step = np.diff(gps_stamps)
    gps_speed = np.hypot(*np.diff(gps_positions, axis=0).T) / np.maximum(step, 1e-3)
    middle = gps_stamps[:-1] + 0.5 * step
    valid = (np.abs(step - 0.2) < 0.02) & (gps_speed < 10.0)
    errors = [np.median(np.abs(gps_speed[valid]
                               - np.interp(middle[valid] - lag, table[:, 0], speed)))
              for lag in lags]
    return float(lags[int(np.argmin(errors))])


def calibrate(folder: Path | str) -> dict[str, float]:
    """Position of the GPS antenna on the car, fitted from dead reckoning against GPS.

    Over every ``ANTENNA_WINDOW`` with dense GPS (at least 60 % of the 5 Hz fixes), the dead
    reckoned antenna position p + R(theta) l is rigidly aligned to the fixes (closed form); the
    lever arm l shared by all windows minimises the aligned residuals (robust loss). Short
    windows keep the odometry drift small; the heading changes within them make l observable.
    """
    from scipy.optimize import least_squares

    from fastslam_ros.tools.evaluation.metrics import align_se2

    folder = Path(folder)
    if (folder / "rfs_slam_txt").is_dir():
        folder = folder / "rfs_slam_txt"
    odom_stamps, odom_poses = load_odometry(folder)
    gps_stamps, gps_positions, _ = load_gps(folder)
    windows = []
    for start in np.arange(gps_stamps[0], gps_stamps[-1], ANTENNA_WINDOW):
        inside = (gps_stamps >= start) & (gps_stamps < start + ANTENNA_WINDOW)
        if np.count_nonzero(inside) < 0.6 * 5.0 * ANTENNA_WINDOW:
            continue
        at = gps_stamps[inside]
        pose = interpolate_poses(odom_stamps, odom_poses, at)
        windows.append((pose, gps_positions[inside]))

    def residuals(lever: np.ndarray) -> np.ndarray:
        out = []
        for pose, fixes in windows:
            c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
            antenna = np.column_stack([pose[:, 0] + c * lever[0] - s * lever[1],
                                       pose[:, 1] + s * lever[0] + c * lever[1]])
            out.append((align_se2(antenna, fixes).apply(antenna) - fixes).ravel())
        return np.concatenate(out)

    fit = least_squares(residuals, np.zeros(2), loss="soft_l1", f_scale=3.0)
    return {"gps_antenna_x": float(fit.x[0]), "gps_antenna_y": float(fit.x[1]),
            "windows": float(len(windows))}
