# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Freiburg "Robot Mapping" course world (``sensor_data.dat``, ``world.dat``) -> recording.

The file has no time stamps: odometry step k (``ODOMETRY r1 t r2``) ends at the synthetic time
``k * step_duration`` (1 s by default), the robot starts at (0, 0, 0) at time 0, and the
``SENSOR id range bearing`` lines that follow step k form the scan at that time (ids given,
bearings wrapped to (-pi, pi]). Landmark truth comes from ``world.dat``; there is no robot truth.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fastslam_ros.core.geometry import wrap_angle
from fastslam_ros.tools.datasets.converters import (Recording, group_by_stamp, polar_to_points,
                                                    read_table, robust_std)

STEP_DURATION = 1.0
"""Synthetic duration of one odometry step (s)."""


def parse_sensor_data(path: Path | str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Odometry steps (S, 3) as (r1, t, r2), and the observations (K, 3) as (id, range, bearing)
    with the index (K,) of the odometry step each follows (0-based)."""
    lines = np.loadtxt(path, dtype=str, ndmin=2)
    is_odometry = lines[:, 0] == "ODOMETRY"
    values = lines[:, 1:4].astype(float)
    step_of_line = np.cumsum(is_odometry) - 1
    is_sensor = lines[:, 0] == "SENSOR"
    if np.any(step_of_line[is_sensor] < 0):
        raise ValueError(f"{path}: SENSOR line before the first ODOMETRY line")
    return values[is_odometry], values[is_sensor], step_of_line[is_sensor]


def integrate_steps(steps: np.ndarray, start_pose: np.ndarray = np.zeros(3)) -> np.ndarray:
    """Poses (S+1, 3) after each (r1, t, r2) step: x += t cos(th + r1), ..., th += r1 + r2."""
    rotation1, translation, rotation2 = steps.T
    headings = start_pose[2] + np.concatenate(([0.0], np.cumsum(rotation1 + rotation2)))
    travel = headings[:-1] + rotation1
    poses = np.empty((len(steps) + 1, 3))
    poses[:, 0] = start_pose[0] + np.concatenate(([0.0], np.cumsum(translation * np.cos(travel))))
    poses[:, 1] = start_pose[1] + np.concatenate(([0.0], np.cumsum(translation * np.sin(travel))))
    poses[:, 2] = wrap_angle(headings)
    return poses


def load_freiburg(folder: Path | str, step_duration: float = STEP_DURATION) -> Recording:
    """Convert the course world folder to a :class:`Recording`."""
    folder = Path(folder)
    steps, observations, step_index = parse_sensor_data(folder / "sensor_data.dat")
    odom_stamps = step_duration * np.arange(len(steps) + 1)
    odom_poses = integrate_steps(steps)
    points = polar_to_points(observations[:, 1], wrap_angle(observations[:, 2]))
    scan_stamps, scan_points, scan_ids = group_by_stamp(
        odom_stamps[step_index + 1], points, observations[:, 0].astype(np.int32))
    world = read_table(folder / "world.dat", 3)
    counts = {"odometry_steps": len(steps), "observations": len(observations)}
    return Recording(odom_stamps, odom_poses, scan_stamps, scan_points, scan_ids,
                     landmark_positions=world[:, 1:3].copy(),
                     landmark_ids=world[:, 0].astype(np.int32), counts=counts)


def calibrate(folder: Path | str) -> dict[str, float]:
    """sigma_range and sigma_bearing: robust std of the measurement residuals against the
    dead-reckoning pose and ``world.dat`` (an upper bound: the odometry error is included)."""
    folder = Path(folder)
    steps, observations, step_index = parse_sensor_data(folder / "sensor_data.dat")
    poses = integrate_steps(steps)[step_index + 1]
    world = read_table(folder / "world.dat", 3)
    landmark = world[np.searchsorted(world[:, 0], observations[:, 0]), 1:3]
    delta = landmark - poses[:, :2]
    range_residual = observations[:, 1] - np.hypot(delta[:, 0], delta[:, 1])
    bearing_residual = wrap_angle(observations[:, 2] - np.arctan2(delta[:, 1], delta[:, 0])
                                  + poses[:, 2])
    return {"sigma_range": robust_std(range_residual),
            "sigma_bearing": robust_std(bearing_residual)}
