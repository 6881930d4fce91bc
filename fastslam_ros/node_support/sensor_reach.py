# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Whether the observations fit the configured perceptual range (``max_range``, ``field_of_view``).

Feature elimination lowers the existence of every landmark inside the configured range and
opening that a reading does not see. A range or an opening wider than the sensor's therefore
removes real landmarks, silently; a narrower opening never confirms the landmarks seen at its
edges. (Observations beyond ``max_range`` are dropped and counted by the node: a range below the
sensor's is a valid way to leave out far, noisy detections.) ``ReachCheck`` collects the first
observations and says once, in a sentence naming the parameter, when the configuration does not
describe them.
"""
from __future__ import annotations

import numpy as np

MIN_POINTS = 500
"""Observations collected before the verdict: enough for the far and wide ones to show up."""

USED_FRACTION = 0.6
"""The 99th percentile of the observed ranges (bearings) must reach this share of max_range
(of half the opening); below it the configured reach is much wider than the sensor's."""

OUTSIDE_FRACTION = 0.05
"""Share of observations outside the configured opening above which it is too narrow."""


class ReachCheck:
    """One-time comparison of the observed reach with ``max_range`` and ``field_of_view``."""

    def __init__(self, max_range: float, field_of_view: float, min_points: int = MIN_POINTS):
        self.max_range = max_range
        self.half_opening = 0.5 * field_of_view
        self.min_points = min_points
        self._ranges: list[np.ndarray] = []
        self._bearings: list[np.ndarray] = []
        self._count = 0
        self.problems: list[str] | None = None
        """None until decided; then the sentences describing each mismatch (empty: it fits)."""

    def add(self, ranges: np.ndarray, bearings: np.ndarray) -> list[str] | None:
        """Collect one reading's finite observations (m, rad in the sensor frame).

        Returns the problems once, on the reading that completes the sample; None otherwise.
        """
        if self.problems is not None:
            return None
        finite = np.isfinite(ranges) & np.isfinite(bearings)
        self._ranges.append(np.asarray(ranges, dtype=float)[finite])
        self._bearings.append(np.abs(np.asarray(bearings, dtype=float)[finite]))
        self._count += int(np.count_nonzero(finite))
        if self._count < self.min_points:
            return None
        self.problems = self._verdict(np.concatenate(self._ranges), np.concatenate(self._bearings))
        self._ranges, self._bearings = [], []
        return self.problems

    def _verdict(self, ranges: np.ndarray, bearings: np.ndarray) -> list[str]:
        problems = []
        far, wide = np.percentile(ranges, 99.0), np.percentile(bearings, 99.0)
        outside = float(np.mean(bearings > self.half_opening))
        sample = f"(99th percentile of the first {ranges.size} observations)"
        if far < USED_FRACTION * self.max_range:
            problems.append(f"observations reach {far:.1f} m {sample} but max_range is "
                            f"{self.max_range:g} m: landmarks the sensor cannot see lose "
                            "existence every reading; set max_range to the sensor's range")
        if outside > OUTSIDE_FRACTION:
            problems.append(f"{100 * outside:.0f} % of the observations lie outside "
                            f"field_of_view {2 * self.half_opening:.2f} rad: set it to the "
                            "sensor's opening")
        elif wide < USED_FRACTION * self.half_opening:
            problems.append(f"observations lie within +-{wide:.2f} rad {sample} but "
                            f"field_of_view is {2 * self.half_opening:.2f} rad: landmarks "
                            "outside the sensor's opening lose existence every reading; set "
                            "field_of_view to the sensor's opening")
        return problems
