# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Moving objects over time: a detection where an earlier scan saw free space, or next to
where an earlier scan saw it, is no landmark.

In one scan a walking person's body looks like a trunk. Over half a second a walker moves
0.6 m (1.2 m/s) while a pole stays put, and odometry drifts little. ``StaticFilter`` keeps the
last scans, each with its sensor's odometry pose and its detections. A detection of the current
scan is put in the odometry frame and compared with each reference scan (the newest scans at
least ``window`` and ``window / 2`` s older); it is something that moved when

* every beam of the reference scan crossing the disc of radius ``tolerance`` (+
  ``heading_tolerance`` per metre of range) around it went beyond the disc: that scan saw the
  place empty (a walker crossing the line of sight); or
* the reference scan's nearest detection lies beyond that radius but within it plus
  ``DISPLACEMENT_SPEED`` times the lag: the same object, moved (a walker going along the line
  of sight, which hides its own earlier place).

A detection is dropped on that evidence only: a pole that a scan missed, that was hidden or
out of view keeps being reported, and so does everything before a reference scan exists.
A person standing still, or turning round, stays where it was seen and is reported.

A laser that sweeps while the robot moves takes each beam from elsewhere: a reference scan
keeps the motion of its sweep (``core.sweep``), and a place is looked for in the beams as the
laser had turned and moved by the time it took them.
"""
from __future__ import annotations

from collections import deque

import numpy as np

from fastslam_ros.core.sweep import STILL, Motion, at_beam_time
from fastslam_ros.extractor.scan import RawScan

REFERENCE_LAGS = (1.0, 0.5)
"""Reference scans, in shares of ``window`` before the current scan."""
DISPLACEMENT_SPEED = 2.0
"""m/s: a detection with none of the reference scan's within the tolerance but one within the
tolerance plus this speed times the lag is that one moved (a walker, whichever way it walks)."""
MAX_SCANS = 4000
"""Scans held at most (a bound on memory whatever the scan rate)."""


def to_frame(pose: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N, 2) points given in the frame of ``pose`` (x, y, yaw) in the frame ``pose`` is in."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.column_stack((pose[0] + c * x - s * y, pose[1] + s * x + c * y))


def from_frame(pose: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) (N,) of points (N, 2) in the frame of ``pose``; the inverse of ``to_frame``."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    dx, dy = points[:, 0] - pose[0], points[:, 1] - pose[1]
    return c * dx + s * dy, -s * dx + c * dy


def free_reach(scan: RawScan) -> np.ndarray:
    """(B,) how far (m) each beam saw free space: its return, the scan's maximum for no return
    (REP 117: +inf, at or beyond the maximum; nothing is known beyond it), -inf when blocked
    (NaN, -inf, below the minimum)."""
    ranges = np.asarray(scan.ranges, float)
    with np.errstate(invalid="ignore"):
        reach = np.where(ranges >= scan.range_min, ranges, -np.inf)  # NaN -> -inf
        return np.where(reach >= scan.range_max, scan.range_max, reach)


class _Reference:
    """One held scan: its stamp, sensor pose at the first beam, free reach per beam and the
    motion of its sweep."""

    def __init__(self, stamp: float, pose: np.ndarray, scan: RawScan,
                 points: np.ndarray, motion: Motion) -> None:
        self.stamp, self.pose, self.points, self.motion = stamp, pose, points, motion
        self.reach = free_reach(scan)
        self.angle_min, self.increment = float(scan.angle_min), float(scan.angle_increment)
        self.time_increment = float(scan.time_increment)

    def seen_empty(self, points: np.ndarray, radius: np.ndarray) -> np.ndarray:
        """(N,) whether every beam crossing the disc of ``radius`` (N,) around each point
        (odometry frame) went beyond it; False when part of the disc was out of view. Each
        point is seen from where the laser was when its beam was taken."""
        x, y = from_frame(self.pose, points)
        if self.time_increment and self.motion != STILL:
            beam = np.clip((np.arctan2(y, x) - self.angle_min) / self.increment, 0.0,
                           len(self.reach) - 1)
            x, y = at_beam_time(x, y, np.rint(beam) * self.time_increment, *self.motion)
        distance = np.hypot(x, y)
        outside = distance > radius
        half = np.arcsin(np.clip(radius / np.maximum(distance, 1e-9), 0.0, 1.0))
        first = (np.arctan2(y, x) - half - self.angle_min) / self.increment
        last = (np.arctan2(y, x) + half - self.angle_min) / self.increment
        low = np.ceil(np.minimum(first, last)).astype(int)
        high = np.floor(np.maximum(first, last)).astype(int)
        inside = outside & (low >= 0) & (high < len(self.reach)) & (high >= low)
        if not inside.any():
            return inside
        width = int((high - low)[inside].max()) + 1
        beams = low[:, None] + np.arange(width)[None, :]
        in_disc = beams <= high[:, None]
        beams = np.clip(beams, 0, len(self.reach) - 1)
        beyond = (self.reach[beams] > (distance + radius)[:, None]) | ~in_disc
        return inside & beyond.all(axis=1)

    def displaced(self, points: np.ndarray, radius: np.ndarray, reach: np.ndarray
                  ) -> np.ndarray:
        """(N,) whether the nearest of this scan's detections to each point (odometry frame)
        lies beyond ``radius`` but within ``reach`` (N,)."""
        if not len(self.points):
            return np.zeros(len(points), dtype=bool)
        gaps = points[:, None, :] - self.points[None, :, :]
        nearest = np.sqrt(np.einsum("nmk,nmk->nm", gaps, gaps).min(axis=1))
        return (nearest > radius) & (nearest <= reach)


class StaticFilter:
    """Which detections of a scan are not where earlier scans saw free space (m, s, rad)."""

    def __init__(self, window: float, tolerance: float, heading_tolerance: float = 0.0) -> None:
        self.window, self.tolerance = float(window), float(tolerance)
        self.heading_tolerance = float(heading_tolerance)
        self._scans: deque[_Reference] = deque(maxlen=MAX_SCANS)

    def __len__(self) -> int:
        """Scans held."""
        return len(self._scans)

    def clear(self) -> None:
        """Forget every scan (a reset, a time jump)."""
        self._scans.clear()

    def update(self, stamp: float, pose: np.ndarray, x: np.ndarray, y: np.ndarray,
               scan: RawScan, motion: Motion = STILL) -> np.ndarray:
        """Add a scan (``pose`` its sensor's odometry pose at ``stamp``, its first beam;
        ``motion`` the laser's over its sweep) and its detections (sensor frame at the first
        beam); return the (N,) mask of those that no reference scan saw as empty.

        Scans must come in stamp order; an older stamp than the newest held clears the history
        first (time went back)."""
        if self._scans and stamp < self._scans[-1].stamp:
            self.clear()
        pose, x, y = np.asarray(pose, float), np.asarray(x, float), np.asarray(y, float)
        points = to_frame(pose, x, y)
        radius = self.tolerance + self.heading_tolerance * np.hypot(x, y)
        keep = np.ones(len(points), dtype=bool)
        for lag in REFERENCE_LAGS:
            reference = self._reference(stamp - lag * self.window)
            if reference is not None and len(points):
                reach = radius + DISPLACEMENT_SPEED * (stamp - reference.stamp)
                keep &= ~(reference.seen_empty(points, radius)
                          | reference.displaced(points, radius, reach))
        self._forget(stamp - self.window)
        self._scans.append(_Reference(stamp, pose, scan, points, motion))
        return keep

    def _reference(self, before: float) -> _Reference | None:
        """The newest scan stamped at or before ``before``; None if there is none."""
        stamps = np.fromiter((s.stamp for s in self._scans), float, len(self._scans))
        index = int(np.searchsorted(stamps, before, side="right")) - 1
        return None if index < 0 else self._scans[index]

    def _forget(self, oldest_needed: float) -> None:
        """Drop the scans before the newest one at or before ``oldest_needed`` (no later scan
        can need them)."""
        while len(self._scans) > 1 and self._scans[1].stamp <= oldest_needed:
            self._scans.popleft()
