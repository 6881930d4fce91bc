# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Static landmarks over time: a detection passes only when earlier scans saw it in place.

In one scan a walking person's body looks like a trunk. Over half a second a walker moves
0.6 m (1.2 m/s) while a pole stays put, and odometry drifts little. ``StaticFilter`` keeps the
detections of the last scans, each put in the odometry frame with its scan's odometry pose; a
detection of the current scan passes when, in each reference scan, a detection lies within
``tolerance`` of it in the odometry frame. The reference scans are the newest scans at least
``window`` and ``window / 2`` s older than the current one: the second look stops a person who
turns round at the end of a walk (back where it was ``window`` s ago for a moment) from
passing. Until a scan ``window`` s older exists (after a start or a reset) nothing passes.
"""
from __future__ import annotations

from collections import deque

import numpy as np

REFERENCE_LAGS = (1.0, 0.5)
"""Reference scans, in shares of ``window`` before the current scan; a detection must be seen
in place in each."""
MAX_SCANS = 4000
"""Scans held at most (a bound on memory whatever the scan rate)."""


def to_frame(pose: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N, 2) points given in the frame of ``pose`` (x, y, yaw) in the frame ``pose`` is in."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.column_stack((pose[0] + c * x - s * y, pose[1] + s * x + c * y))


class StaticFilter:
    """Which detections of a scan stayed put over ``window`` s (odometry frame, m, s)."""

    def __init__(self, window: float, tolerance: float) -> None:
        self.window, self.tolerance = float(window), float(tolerance)
        self._stamps: deque[float] = deque(maxlen=MAX_SCANS)
        self._points: deque[np.ndarray] = deque(maxlen=MAX_SCANS)

    def __len__(self) -> int:
        """Scans held."""
        return len(self._stamps)

    def clear(self) -> None:
        """Forget every scan (a reset, a time jump)."""
        self._stamps.clear()
        self._points.clear()

    def update(self, stamp: float, pose: np.ndarray, x: np.ndarray, y: np.ndarray
               ) -> np.ndarray:
        """Add a scan's detections (sensor frame, ``pose`` the sensor's odometry pose at
        ``stamp``); return the (N,) mask of those that were in place in every reference scan.

        Scans must come in stamp order; an older stamp than the newest held clears the history
        first (time went back)."""
        if self._stamps and stamp < self._stamps[-1]:
            self.clear()
        points = to_frame(np.asarray(pose, float), np.asarray(x, float), np.asarray(y, float))
        keep = np.ones(len(points), dtype=bool)
        for lag in REFERENCE_LAGS:
            reference = self._reference(stamp - lag * self.window)
            if reference is None:
                keep[:] = False
                break
            if len(points) and keep.any():
                keep &= self._near(points, reference)
        self._forget(stamp - self.window)
        self._stamps.append(stamp)
        self._points.append(points)
        return keep

    def _reference(self, before: float) -> np.ndarray | None:
        """Points of the newest scan stamped at or before ``before``; None if there is none."""
        index = int(np.searchsorted(np.fromiter(self._stamps, float, len(self._stamps)),
                                    before, side="right")) - 1
        return None if index < 0 else self._points[index]

    def _near(self, points: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """(N,) whether each point has a reference point within the tolerance."""
        if not len(reference):
            return np.zeros(len(points), dtype=bool)
        gaps = points[:, None, :] - reference[None, :, :]
        return (np.einsum("nmk,nmk->nm", gaps, gaps) <= self.tolerance ** 2).any(axis=1)

    def _forget(self, oldest_needed: float) -> None:
        """Drop the scans before the newest one at or before ``oldest_needed`` (no later scan
        can need them)."""
        while len(self._stamps) > 1 and self._stamps[1] <= oldest_needed:
            self._stamps.popleft()
            self._points.popleft()
