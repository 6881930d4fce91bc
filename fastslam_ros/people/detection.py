# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A laser scan, and people detected in it: beams ending in free space away from obstacles.

The scan is cut into segments (runs of neighbouring beams whose ranges differ by less than
``segment_jump``) once, in the sensor frame. Which beams of a segment end away from the map's
obstacles depends on the robot pose, so it is decided per robot particle (``far`` (M, B)); a
segment holding at least ``min_detection_beams`` such beams, no wider than
``max_person_width``, is one person for that particle, placed at the middle bearing of those
beams and at their nearest range plus ``person_radius`` (the beams hit the person's front).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fastslam_ros.core.geometry import wrap_angle


@dataclass(frozen=True)
class Scan:
    """One planar laser reading in the sensor frame: ``ranges`` (B,) m (inf: no return, the
    beam saw free space; NaN: no evidence at all) at ``angles`` (B,) rad, evenly spaced from
    ``angle_min`` by ``angle_increment``."""

    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_max: float = np.inf

    @property
    def angles(self) -> np.ndarray:
        return wrap_angle(self.angle_min + self.angle_increment * np.arange(len(self.ranges)))

    def returns(self, min_range: float, max_range: float) -> np.ndarray:
        """Mask of the beams that hit something: finite, in [min_range, min(max_range,
        range_max))."""
        limit = min(max_range, self.range_max)
        with np.errstate(invalid="ignore"):
            return np.isfinite(self.ranges) & (self.ranges >= min_range) & (self.ranges < limit)

    def beam_index(self, bearings: np.ndarray) -> np.ndarray:
        """Index of the beam nearest each bearing (rad), wrapping round a full turn; beams
        outside a partial scan's span clip to its first or last beam."""
        count = len(self.ranges)
        steps = np.rint(wrap_angle(bearings - self.angle_min) / self.angle_increment)
        full_turn = abs(self.angle_increment) * count >= 2.0 * np.pi - 1e-6
        if full_turn:
            return np.mod(steps, count).astype(np.intp)
        return np.clip(steps, 0, count - 1).astype(np.intp)


@dataclass
class Segments:
    """Beams (indices into the scan, in scan order but starting at a break) grouped into
    segments: ``beams`` (K,), ``starts`` (S,) offsets of each segment in ``beams``,
    ``ranges`` (K,) and unwrapped ``angles`` (K,) of those beams."""

    beams: np.ndarray
    starts: np.ndarray
    ranges: np.ndarray
    angles: np.ndarray


def segment_scan(scan: Scan, returns: np.ndarray, jump: float) -> Segments:
    """Cut the returning beams into runs of neighbours closer than ``jump`` in range.

    The scan is rotated to start at a break (a missing return or a jump), so that an object
    seen across the start of a full-turn scan is one segment.
    """
    ranges = np.where(returns, scan.ranges, np.inf)
    count = len(ranges)
    with np.errstate(invalid="ignore"):
        joined = returns & np.roll(returns, 1) & (np.abs(ranges - np.roll(ranges, 1)) <= jump)
    full_turn = abs(scan.angle_increment) * count >= 2.0 * np.pi - 1e-6
    if not full_turn and count:
        joined[0] = False
    breaks = np.flatnonzero(~joined)
    shift = int(breaks[0]) if len(breaks) else 0
    order = np.roll(np.arange(count), -shift)
    keep = returns[order]
    beams = order[keep]
    starts = np.flatnonzero(~joined[order][keep])
    if len(beams) and (len(starts) == 0 or starts[0] != 0):
        starts = np.concatenate([[0], starts])
    angles = np.unwrap(scan.angle_min + scan.angle_increment * beams.astype(float)) \
        if len(beams) else np.zeros(0)
    return Segments(beams, starts.astype(np.intp), scan.ranges[beams].astype(float), angles)


@dataclass
class Detections:
    """Per robot particle and candidate segment: ``valid`` (M, S), and the detection's range
    ``ranges`` (M, S) and ``bearings`` (M, S) in the sensor frame."""

    valid: np.ndarray
    ranges: np.ndarray
    bearings: np.ndarray


def detect_people(segments: Segments, far: np.ndarray, min_beams: int, max_width: float,
                  person_radius: float) -> Detections:
    """People per particle from the beams ending away from obstacles (``far`` (M, K), in the
    order of ``segments.beams``)."""
    particles = far.shape[0]
    if len(segments.starts) == 0:
        empty = np.zeros((particles, 0))
        return Detections(empty.astype(bool), empty, empty)
    count = np.add.reduceat(far.astype(np.int32), segments.starts, axis=1)
    candidate = (count >= min_beams).any(axis=0)
    if not candidate.any():
        empty = np.zeros((particles, 0))
        return Detections(empty.astype(bool), empty, empty)
    nearest = np.minimum.reduceat(np.where(far, segments.ranges, np.inf), segments.starts, axis=1)
    first = np.minimum.reduceat(np.where(far, segments.angles, np.inf), segments.starts, axis=1)
    last = np.maximum.reduceat(np.where(far, segments.angles, -np.inf), segments.starts, axis=1)
    count, nearest = count[:, candidate], nearest[:, candidate]
    first, last = first[:, candidate], last[:, candidate]
    with np.errstate(invalid="ignore"):
        width = 2.0 * nearest * np.sin(0.5 * np.clip(last - first, 0.0, np.pi))
        valid = (count >= min_beams) & (width <= max_width)
        bearings = np.where(valid, wrap_angle(np.where(valid, 0.5 * (first + last), 0.0)), 0.0)
    ranges = np.where(valid, nearest + person_radius, 0.0)
    return Detections(valid, ranges, bearings)
