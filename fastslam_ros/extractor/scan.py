# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A raw planar laser scan, the REP 117 meaning of its beams, and its segments.

Each beam is a return (a finite range in [min_range, max_range)), free (+inf, or a range at or
beyond the scan's or the extractor's maximum: nothing up to there) or blocked (NaN, -inf or a
range below the minimum: something may stand in front, unseen). A segment is a run of
neighbouring returns whose ranges differ by at most ``jump``; its neighbours are the beams just
outside it, which tell whether something in front cuts it (an occlusion) or the scan's edge
does.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

FREE, RETURN, BLOCKED = 0, 1, 2
"""Beam kinds (REP 117): no return, a usable return, possibly hidden by something near."""
NO_NEIGHBOUR = -1
"""A segment's neighbour beyond the first or last beam of a scan that is not a full turn."""


@dataclass(frozen=True)
class RawScan:
    """One ``sensor_msgs/LaserScan`` as arrays: ``ranges`` (B,) m as sent (inf, NaN kept),
    ``intensities`` (B,) or empty, beam k at ``angle_min + k * angle_increment`` rad, taken
    ``k * time_increment`` s after the first beam (0: all at once)."""

    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float = 0.0
    range_max: float = math.inf
    intensities: np.ndarray = field(default_factory=lambda: np.zeros(0))
    time_increment: float = 0.0

    @property
    def full_turn(self) -> bool:
        """Whether the beams go all the way round (the last beam neighbours the first)."""
        return abs(self.angle_increment) * len(self.ranges) >= 2.0 * math.pi - 1e-6

    def angles(self) -> np.ndarray:
        """Bearing (rad) of every beam in the sensor frame."""
        return self.angle_min + self.angle_increment * np.arange(len(self.ranges))

    def beam_kinds(self, min_range: float, max_range: float) -> np.ndarray:
        """FREE, RETURN or BLOCKED per beam (REP 117, with the extractor's range limits)."""
        ranges = np.asarray(self.ranges, dtype=float)
        near = max(min_range, self.range_min if math.isfinite(self.range_min) else 0.0)
        far = min(max_range, self.range_max if self.range_max > 0.0 else math.inf)
        kinds = np.full(len(ranges), BLOCKED, dtype=np.int8)
        with np.errstate(invalid="ignore"):
            kinds[ranges >= far] = FREE  # +inf too; NaN compares False and stays BLOCKED
            kinds[(ranges >= near) & (ranges < far)] = RETURN
        return kinds


@dataclass
class Segments:
    """Runs of neighbouring returns: ``beams`` (K,) beam indices, segment by segment in scan
    order; segment i is ``beams[starts[i]:starts[i] + counts[i]]``; ``left`` and ``right``
    (S,) the beams just before and after it (NO_NEIGHBOUR at a partial scan's edge)."""

    beams: np.ndarray
    starts: np.ndarray
    counts: np.ndarray
    left: np.ndarray
    right: np.ndarray

    @property
    def owner(self) -> np.ndarray:
        """Segment of each entry of ``beams`` (K,)."""
        return np.repeat(np.arange(len(self.starts)), self.counts)

    def select(self, keep: np.ndarray) -> "Segments":
        """The segments where ``keep`` (S,) is True."""
        counts = self.counts[keep]
        starts = (np.cumsum(counts) - counts).astype(np.intp)
        return Segments(self.beams[keep[self.owner]], starts, counts, self.left[keep],
                        self.right[keep])


def segment(ranges: np.ndarray, member: np.ndarray, jump: float, full_turn: bool) -> Segments:
    """Cut the beams where ``member`` (B,) is True into runs of neighbours whose ranges differ
    by at most ``jump``. A full-turn scan is read from a break, so an object across its first
    beam is one segment."""
    count = len(ranges)
    with np.errstate(invalid="ignore"):
        joined = member & np.roll(member, 1) & (np.abs(ranges - np.roll(ranges, 1)) <= jump)
    if count and (not full_turn or joined.all()):
        joined[0] = False
    shift = int(np.argmax(~joined)) if count else 0
    order = np.roll(np.arange(count), -shift)
    member_o, joined_o = member[order], joined[order]
    first = np.flatnonzero(member_o & ~joined_o)
    last = np.flatnonzero(member_o & ~np.roll(joined_o, -1))
    if full_turn:
        left, right = order[(first - 1) % count], order[(last + 1) % count]
    else:
        left = np.where(first > 0, order[np.maximum(first - 1, 0)], NO_NEIGHBOUR)
        right = np.where(last < count - 1, order[np.minimum(last + 1, count - 1)], NO_NEIGHBOUR)
    counts = last - first + 1
    starts = np.cumsum(counts) - counts
    return Segments(order[member_o], starts.astype(np.intp), counts.astype(np.intp),
                    left.astype(np.intp), right.astype(np.intp))


def occluded(segments: Segments, ranges: np.ndarray, kinds: np.ndarray,
             jump: float) -> np.ndarray:
    """Per segment: cut at either edge by the scan's edge, by a blocked beam or by a return
    nearer than the segment's edge by more than ``jump`` (the object may go on behind)."""
    ends = segments.starts + segments.counts - 1
    cut = np.zeros(len(segments.starts), dtype=bool)
    for neighbour, edge in ((segments.left, segments.beams[segments.starts]),
                            (segments.right, segments.beams[ends])):
        beam = np.maximum(neighbour, 0)
        with np.errstate(invalid="ignore"):
            nearer = (kinds[beam] == RETURN) & (ranges[beam] < ranges[edge] - jump)
        cut |= (neighbour == NO_NEIGHBOUR) | (kinds[beam] == BLOCKED) | nearer
    return cut
