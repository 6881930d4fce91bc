# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The readings a filter processed, kept for the map refinement's least squares
(``map_refinement.refine``) and the online smoother: per reading its stamp, the odometry pose
and its observations, within bounded memory."""
from __future__ import annotations

import numpy as np

from .geometry import compose_floats, wrap_angle
from .observation import MIN_OBSERVATION_RANGE

MAX_READINGS = 1 << 15
"""Readings the log keeps at most (32,768, about 1 MiB of poses; 1.8 h at 5 Hz in full)."""
MAX_OBSERVATIONS = 1 << 20
"""Observations the log keeps at most (1,048,576: 24 MiB of range, bearing and id)."""

class ReadingLog:
    """The readings a filter processed: per reading its stamp, the odometry pose (the composed
    increments given to ``move``) and its observations (range, bearing in the sensor frame,
    id). Recording a reading copies it into arrays grown by doubling up to the caps; when a cap
    is reached, the older half of the readings is thinned to every other one."""

    def __init__(self, max_readings: int = MAX_READINGS,
                 max_observations: int = MAX_OBSERVATIONS, origin=(0.0, 0.0, 0.0)) -> None:
        self.max_readings = max(int(max_readings), 4)
        self.max_observations = max(int(max_observations), 4)
        self.clear(origin)

    def clear(self, origin=(0.0, 0.0, 0.0)) -> None:
        """Forget every reading (a reset, an initial pose or a new map): the odometry chain
        restarts at ``origin``, the robot's pose (map frame) at that moment."""
        self.origin = np.array(origin, dtype=float).reshape(3)
        """Pose (map frame) where the odometry chain starts: the refinement's gauge."""
        self._odometry_pose = (0.0, 0.0, 0.0)
        self._count = 0
        self._observation_count = 0
        self._stamps = np.zeros(64)
        self._odometry = np.zeros((64, 3))
        self._starts = np.zeros(65, np.int64)
        self._ranges = np.zeros(256)
        self._bearings = np.zeros(256)
        self._labels = np.zeros(256, np.int64)
        self.thinned = False
        """Readings were dropped to stay within the caps."""

    def __len__(self) -> int:
        return self._count

    @property
    def num_observations(self) -> int:
        """Observations logged (after any thinning)."""
        return self._observation_count

    def move(self, step) -> None:
        """Odometry increment (dx, dy, dtheta) in the robot frame since the last call."""
        self._odometry_pose = compose_floats(self._odometry_pose, step)

    @property
    def odometry_pose(self) -> np.ndarray:
        """(3,) the odometry chain's pose now (every increment given to ``move``)."""
        return np.array(self._odometry_pose)

    def record(self, stamp: float, ranges: np.ndarray, bearings: np.ndarray,
               labels: np.ndarray) -> None:
        """One reading, as the filter received it (unusable observations are skipped later)."""
        count = len(ranges)
        if count > self.max_observations // 2:
            ranges, bearings, labels = (a[:self.max_observations // 2]
                                        for a in (ranges, bearings, labels))
            count = len(ranges)
        while (self._count >= self.max_readings
               or self._observation_count + count > self.max_observations):
            self._thin()
        if self._count == len(self._stamps):
            grow = min(2 * len(self._stamps), self.max_readings)
            self._stamps = np.resize(self._stamps, grow)
            self._odometry = np.resize(self._odometry, (grow, 3))
            self._starts = np.resize(self._starts, grow + 1)
        end = self._observation_count + count
        if end > len(self._ranges):
            grow = min(max(2 * len(self._ranges), end), self.max_observations)
            self._ranges = np.resize(self._ranges, grow)
            self._bearings = np.resize(self._bearings, grow)
            self._labels = np.resize(self._labels, grow)
        index = self._count
        self._stamps[index] = stamp
        self._odometry[index] = self._odometry_pose
        self._ranges[self._observation_count:end] = ranges
        self._bearings[self._observation_count:end] = bearings
        self._labels[self._observation_count:end] = labels
        self._starts[index] = self._observation_count
        self._starts[index + 1] = end
        self._observation_count = end
        self._count += 1

    def _thin(self) -> None:
        """Keep every other reading of the older half, all of the newer half."""
        count = self._count
        half = count // 2
        keep = np.concatenate([np.arange(0, half, 2), np.arange(half, count)])
        starts, ends = self._starts[keep], self._starts[keep + 1]
        lengths = ends - starts
        source = np.repeat(starts - np.concatenate([[0], np.cumsum(lengths)[:-1]]), lengths)
        source += np.arange(int(lengths.sum()))
        kept = len(keep)
        for name in ("_ranges", "_bearings", "_labels"):
            array = getattr(self, name)
            array[:len(source)] = array[source]
        self._stamps[:kept] = self._stamps[keep]
        self._odometry[:kept] = self._odometry[keep]
        self._starts[1:kept + 1] = np.cumsum(lengths)
        self._starts[0] = 0
        self._count = kept
        self._observation_count = int(lengths.sum())
        self.thinned = True

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (T,), odometry poses (T, 3)) of the logged readings, without their
        observations (what a path needs)."""
        return self._stamps[:self._count].copy(), self._odometry[:self._count].copy()

    def readings(self):
        """(stamps (T,), odometry poses (T, 3), reading index of each observation (K,), ranges
        (K,), bearings (K,), ids (K,)), the observations' unusable ones (non-finite, or a range
        below ``MIN_OBSERVATION_RANGE``) left out."""
        count, total = self._count, self._observation_count
        lengths = np.diff(self._starts[:count + 1])
        reading = np.repeat(np.arange(count), lengths)
        ranges, bearings = self._ranges[:total], self._bearings[:total]
        usable = (np.isfinite(ranges) & np.isfinite(bearings)
                  & (ranges >= MIN_OBSERVATION_RANGE))
        return (self._stamps[:count].copy(), self._odometry[:count].copy(), reading[usable],
                ranges[usable], wrap_angle(bearings[usable]), self._labels[:total][usable])
