# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Dataset converters: parse public SLAM datasets into the arrays of bag schema v1.

Each module (``mrclam``, ``victoria_park``, ``freiburg``) reads its dataset with vectorized numpy,
returns a :class:`Recording` (plain arrays, no ROS types) and knows how to calibrate its noise
parameters from the data. :func:`Recording.to_schema_bag` turns a recording into the
``SchemaBag`` that ``fastslam_ros.tools.bags.bag_schema.write_schema_bag`` writes.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fastslam_ros.core.geometry import wrap_angle


def read_table(path: Path | str, columns: int) -> np.ndarray:
    """Read a whitespace-separated numeric text file into a (N, columns) float array.

    Handles ``#`` comment lines, tabs, CRLF line ends and an empty file.
    """
    with warnings.catch_warnings():  # an empty file is an empty table, not a warning
        warnings.simplefilter("ignore", UserWarning)
        table = np.loadtxt(path, comments="#", ndmin=2)
    if table.size == 0:
        return np.zeros((0, columns))
    if table.shape[1] < columns:
        raise ValueError(f"{path}: expected {columns} columns, found {table.shape[1]}")
    return table[:, :columns]


def integrate_unicycle(stamps: np.ndarray, speeds: np.ndarray, yaw_rates: np.ndarray,
                       start_pose: np.ndarray) -> np.ndarray:
    """Poses (N, 3) at ``stamps`` from piecewise-constant (v, omega) commands.

    Command i holds from stamps[i] to stamps[i+1]; the pose at stamps[0] is ``start_pose``.
    Each step is the exact circular arc: the chord has length v dt sinc(omega dt / 2) and points
    along the heading at mid-step, which also covers omega = 0 without a special case.
    """
    durations = np.diff(stamps)
    turn = yaw_rates[:-1] * durations
    headings = start_pose[2] + np.concatenate(([0.0], np.cumsum(turn)))
    chord = speeds[:-1] * durations * np.sinc(turn / (2.0 * np.pi))
    mid_heading = headings[:-1] + 0.5 * turn
    poses = np.empty((len(stamps), 3))
    poses[:, 0] = start_pose[0] + np.concatenate(([0.0], np.cumsum(chord * np.cos(mid_heading))))
    poses[:, 1] = start_pose[1] + np.concatenate(([0.0], np.cumsum(chord * np.sin(mid_heading))))
    poses[:, 2] = wrap_angle(headings)
    return poses


def group_by_stamp(stamps: np.ndarray, points: np.ndarray, ids: np.ndarray
                   ) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """Split time-sorted rows into one scan per distinct stamp: (stamps, points list, ids list)."""
    unique_stamps, starts = np.unique(stamps, return_index=True)
    order = np.argsort(starts)
    unique_stamps, starts = unique_stamps[order], starts[order]
    return (unique_stamps, np.split(points, starts[1:]),
            np.split(ids.astype(np.int32), starts[1:]))


def polar_to_points(ranges: np.ndarray, bearings: np.ndarray) -> np.ndarray:
    """(K, 2) Cartesian points of range/bearing observations in their sensor frame."""
    return np.column_stack((ranges * np.cos(bearings), ranges * np.sin(bearings)))


def isolated_jumps(positions: np.ndarray, window: int, bound: float) -> np.ndarray:
    """Mask of the samples (N, 2) farther than ``bound`` from the running median of ``window``
    samples around them: a real motion moves the median with it, an isolated jump does not."""
    from scipy.ndimage import median_filter

    size = min(window, len(positions)) | 1
    median_x = median_filter(positions[:, 0], size=size, mode="nearest")
    median_y = median_filter(positions[:, 1], size=size, mode="nearest")
    return np.hypot(positions[:, 0] - median_x, positions[:, 1] - median_y) > bound


def robust_std(values: np.ndarray) -> float:
    """Standard deviation estimated from the median absolute deviation (outlier tolerant)."""
    values = np.asarray(values, dtype=float)
    return float(1.4826 * np.median(np.abs(values - np.median(values))))


@dataclass
class Recording:
    """One converted run as plain arrays (SI units, radians in (-pi, pi]).

    ``odometry_poses`` are in the odom frame; ``scan_points`` in the sensor frame; the ground
    truth (robot base pose, or position only) and the landmark truth in the map frame.
    ``counts`` records rows read and dropped, by reason, for the converter's summary.
    """

    odometry_stamps: np.ndarray
    odometry_poses: np.ndarray
    scan_stamps: np.ndarray
    scan_points: list[np.ndarray]
    scan_ids: list[np.ndarray]
    ground_truth_stamps: np.ndarray | None = None
    ground_truth_poses: np.ndarray | None = None
    ground_truth_position_only: bool = False
    landmark_positions: np.ndarray | None = None
    landmark_ids: np.ndarray | None = None
    counts: dict[str, int] = field(default_factory=dict)
    ground_truth_frame: str = "base_link"
    """The point of the robot the ground truth measures (a GPS antenna: ``gps_antenna``)."""
    ground_truth_offset: tuple[float, float] | None = None
    """(x, y) of that point in the base frame, when it is not the base itself."""

    def head(self, duration: float) -> "Recording":
        """The first ``duration`` seconds (from the first odometry stamp) of this recording."""
        end = self.odometry_stamps[0] + duration
        odometry = self.odometry_stamps <= end
        scans = np.flatnonzero(self.scan_stamps <= end)
        truth = None if self.ground_truth_stamps is None else self.ground_truth_stamps <= end
        return Recording(
            self.odometry_stamps[odometry], self.odometry_poses[odometry],
            self.scan_stamps[scans], [self.scan_points[i] for i in scans],
            [self.scan_ids[i] for i in scans],
            None if truth is None else self.ground_truth_stamps[truth],
            None if truth is None else self.ground_truth_poses[truth],
            self.ground_truth_position_only, self.landmark_positions, self.landmark_ids,
            dict(self.counts), self.ground_truth_frame, self.ground_truth_offset)

    def to_schema_bag(self):
        """The ``bag_schema.SchemaBag`` of this recording."""
        from fastslam_ros.tools.bags.bag_schema import (LandmarkScans, LandmarkSet, PoseSeries,
                                                        SchemaBag)

        ground_truth = None
        if self.ground_truth_stamps is not None:
            ground_truth = PoseSeries(
                self.ground_truth_stamps, self.ground_truth_poses, frame_id="map",
                child_frame_id=self.ground_truth_frame,
                position_only=self.ground_truth_position_only,
                reference_offset=(None if self.ground_truth_offset is None
                                  else np.asarray(self.ground_truth_offset, dtype=float)))
        landmarks_truth = None
        if self.landmark_positions is not None:
            landmarks_truth = LandmarkSet(self.landmark_positions,
                                          self.landmark_ids.astype(np.int32))
        return SchemaBag(
            odometry=PoseSeries(self.odometry_stamps, self.odometry_poses),
            scans=LandmarkScans(self.scan_stamps, self.scan_points, self.scan_ids),
            ground_truth=ground_truth,
            landmarks_truth=landmarks_truth,
        )

    def summary(self) -> str:
        """One line per message kind and per count, for the CLI."""
        lines = [f"odometry: {len(self.odometry_stamps)} poses over "
                 f"{self.odometry_stamps[-1] - self.odometry_stamps[0]:.1f} s",
                 f"landmark scans: {len(self.scan_stamps)} "
                 f"({sum(len(p) for p in self.scan_points)} observations)"]
        if self.ground_truth_stamps is not None:
            kind = "positions" if self.ground_truth_position_only else "poses"
            lines.append(f"ground truth: {len(self.ground_truth_stamps)} {kind}")
        if self.landmark_positions is not None:
            lines.append(f"landmark truth: {len(self.landmark_positions)} landmarks")
        lines += [f"{name}: {value}" for name, value in self.counts.items()]
        return "\n".join(lines)
