# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Point landmarks from one planar laser scan: circles (poles, trunks, legs) and reflectors.

Circles: the returns are cut into segments at range jumps (``scan.segment``); a segment is
fitted with a circle (``circle_fit``, Taubin) only when it has ``min_beams`` returns, is cut by
no occlusion or scan edge at either end (its visible arc would be short on one side and its
centre biased) and is no longer end to end than ``max_diameter`` (walls). A fit is a landmark
when its points do not lie on a straight line (``straight_residual``), its diameter is in
[min_diameter, max_diameter], its RMS residual is at most ``max_residual`` and its centre lies
behind the returns (a convex outline seen from outside, not an inside corner).

Reflectors: returns brighter than ``reflector_intensity`` (or, when it is 0, than the scan's
median intensity plus ``reflector_mads`` robust standard deviations) are grouped into clusters
of neighbours; a cluster of at least ``reflector_min_beams`` returns and no wider than
``reflector_max_width`` is a post whose centre lies ``reflector_radius`` behind the cluster's
mean return, along its mean bearing.

Every step is a numpy operation over all beams or all segments at once.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from fastslam_ros.core.sweep import at_first_beam
from fastslam_ros.extractor.circle_fit import fit_circles, segment_means
from fastslam_ros.extractor.scan import RETURN, RawScan, Segments, occluded, segment
from fastslam_ros.extractor.settings import ExtractorSettings

MAD_TO_SIGMA = 1.4826
"""Standard deviation of a normal distribution per unit of median absolute deviation."""
REJECTIONS = ("few_beams", "occluded", "long", "straight", "diameter", "residual", "concave",
              "reflector_small", "reflector_wide")
"""Why a segment or a cluster is no landmark, in the order the tests are made."""


@dataclass
class Landmarks:
    """Landmarks of one scan in the sensor frame, (N,) each: centre ``x``, ``y`` (m),
    ``radius`` (m), mean ``intensity`` of their returns (0 without intensities), whether
    each is a ``reflector`` (else a fitted circle) and ``beam_time``, when (s after the scan's
    first beam) the laser took its middle beam."""

    x: np.ndarray = field(default_factory=lambda: np.zeros(0))
    y: np.ndarray = field(default_factory=lambda: np.zeros(0))
    radius: np.ndarray = field(default_factory=lambda: np.zeros(0))
    intensity: np.ndarray = field(default_factory=lambda: np.zeros(0))
    reflector: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    beam_time: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return len(self.x)

    def subset(self, keep: np.ndarray) -> "Landmarks":
        """The landmarks where ``keep`` is True."""
        return Landmarks(self.x[keep], self.y[keep], self.radius[keep], self.intensity[keep],
                         self.reflector[keep], self.beam_time[keep])

    def at_first_beam(self, yaw_rate: float, velocity: tuple[float, float]) -> "Landmarks":
        """The landmarks where the laser at its first beam sees them, for a laser turning at
        ``yaw_rate`` (rad/s) and moving at ``velocity`` (m/s, its frame) while it swept
        (``core.sweep.at_first_beam``)."""
        x, y = at_first_beam(self.x, self.y, self.beam_time, yaw_rate, velocity)
        return dataclasses.replace(self, x=x, y=y)

    @staticmethod
    def concatenate(parts: list["Landmarks"]) -> "Landmarks":
        """All landmarks of ``parts``, in order."""
        return Landmarks(*(np.concatenate([getattr(part, name) for part in parts])
                           for name in ("x", "y", "radius", "intensity", "reflector",
                                        "beam_time")))


@dataclass
class Extraction:
    """The landmarks of a scan, how many segments it had, how many were rejected and why
    (``REJECTIONS``) and the reflector intensity threshold used (NaN: none)."""

    landmarks: Landmarks
    segments: int = 0
    rejected: dict[str, int] = field(default_factory=lambda: dict.fromkeys(REJECTIONS, 0))
    threshold: float = float("nan")


def extract_landmarks(scan: RawScan, settings: ExtractorSettings) -> Extraction:
    """The landmarks ``settings.detector`` finds in ``scan`` (settings already validated)."""
    ranges = np.asarray(scan.ranges, dtype=float)
    kinds = scan.beam_kinds(settings.min_range, settings.max_range)
    angles = scan.angles()
    result = Extraction(Landmarks())
    parts = []
    if settings.detector in ("reflectors", "both"):
        parts.append(_reflectors(scan, ranges, kinds, angles, settings, result))
    if settings.detector in ("circles", "both"):
        circles = _circles(scan, ranges, kinds, angles, settings, result)
        if parts and len(parts[0]) and len(circles):
            gap = np.hypot(circles.x[:, None] - parts[0].x[None, :],
                           circles.y[:, None] - parts[0].y[None, :])
            circles = circles.subset(gap.min(axis=1) > settings.max_diameter)
        parts.append(circles)
    result.landmarks = Landmarks.concatenate(parts)
    return result


def _points(segments: Segments, ranges: np.ndarray,
            angles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ranges and x, y (sensor frame) of the segments' beams, in segment order."""
    r, a = ranges[segments.beams], angles[segments.beams]
    return r, r * np.cos(a), r * np.sin(a)


def _mean_intensity(scan: RawScan, segments: Segments) -> np.ndarray:
    """Mean intensity of each segment's beams (0 when the scan has none)."""
    if len(scan.intensities) != len(scan.ranges) or not len(segments.starts):
        return np.zeros(len(segments.starts))
    values = np.nan_to_num(np.asarray(scan.intensities, dtype=float)[segments.beams])
    return segment_means(values, segments.starts, segments.counts)


def _beam_times(scan: RawScan, segments: Segments) -> np.ndarray:
    """When (s after the first beam) the laser took each segment's middle beam (a segment
    across a full turn's first beam is taken at both ends of the sweep: its middle beam's
    time is one of them)."""
    return segments.beams[segments.starts + segments.counts // 2] * scan.time_increment


def _reject(result: Extraction, reason: str, mask: np.ndarray) -> np.ndarray:
    """Count the segments of ``mask`` under ``reason``; return ~mask."""
    result.rejected[reason] += int(np.count_nonzero(mask))
    return ~mask


def _circles(scan: RawScan, ranges: np.ndarray, kinds: np.ndarray, angles: np.ndarray,
             s: ExtractorSettings, result: Extraction) -> Landmarks:
    """Circle landmarks: segments fitted with circles, kept as the module docstring says."""
    segments = segment(ranges, kinds == RETURN, s.segment_jump, scan.full_turn)
    result.segments = len(segments.starts)
    if not result.segments:
        return Landmarks()
    _, x, y = _points(segments, ranges, angles)
    ends = segments.starts + segments.counts - 1
    extent = np.hypot(x[ends] - x[segments.starts], y[ends] - y[segments.starts])
    keep = _reject(result, "few_beams", segments.counts < s.min_beams)
    keep[keep] = _reject(result, "occluded",
                         occluded(segments.select(keep), ranges, kinds, s.segment_jump))
    keep[keep] = _reject(result, "long", extent[keep] > s.max_diameter)
    if not keep.any():
        return Landmarks()
    segments = segments.select(keep)
    r, x, y = _points(segments, ranges, angles)
    fits = fit_circles(x, y, segments.starts)
    behind = np.hypot(fits.x, fits.y) > segment_means(r, segments.starts, segments.counts)
    keep = _reject(result, "straight", fits.line_residual < s.straight_residual)
    diameter = 2.0 * fits.radius
    keep[keep] = _reject(result, "diameter", (diameter[keep] < s.min_diameter)
                         | (diameter[keep] > s.max_diameter))
    keep[keep] = _reject(result, "residual", fits.residual[keep] > s.max_residual)
    keep[keep] = _reject(result, "concave", ~behind[keep])
    return Landmarks(fits.x[keep], fits.y[keep], fits.radius[keep],
                     _mean_intensity(scan, segments)[keep], np.zeros(int(keep.sum()), bool),
                     _beam_times(scan, segments)[keep])


def reflector_threshold(intensities: np.ndarray, mads: float) -> float:
    """Intensity above which a return is a reflector's: median + ``mads`` robust standard
    deviations (1.4826 median absolute deviations) of ``intensities``."""
    if not len(intensities):
        return float("inf")
    median = float(np.median(intensities))
    spread = MAD_TO_SIGMA * float(np.median(np.abs(intensities - median)))
    return median + mads * spread


def _reflectors(scan: RawScan, ranges: np.ndarray, kinds: np.ndarray, angles: np.ndarray,
                s: ExtractorSettings, result: Extraction) -> Landmarks:
    """Reflector landmarks: clusters of bright returns, as the module docstring says."""
    if len(scan.intensities) != len(ranges):
        return Landmarks()
    intensities = np.asarray(scan.intensities, dtype=float)
    returns = (kinds == RETURN) & np.isfinite(intensities)
    threshold = s.reflector_intensity or reflector_threshold(intensities[returns],
                                                             s.reflector_mads)
    result.threshold = float(threshold)
    clusters = segment(ranges, returns & (intensities > threshold), s.segment_jump,
                       scan.full_turn)
    if not len(clusters.starts):
        return Landmarks()
    r, x, y = _points(clusters, ranges, angles)
    ends = clusters.starts + clusters.counts - 1
    width = np.hypot(x[ends] - x[clusters.starts], y[ends] - y[clusters.starts])
    keep = _reject(result, "reflector_small", clusters.counts < s.reflector_min_beams)
    keep[keep] = _reject(result, "reflector_wide", width[keep] > s.reflector_max_width)
    clusters = clusters.select(keep)
    if not len(clusters.starts):
        return Landmarks()
    r, x, y = _points(clusters, ranges, angles)
    starts, counts = clusters.starts, clusters.counts
    bearing = np.arctan2(segment_means(y / r, starts, counts),
                         segment_means(x / r, starts, counts))
    reach = segment_means(r, starts, counts) + s.reflector_radius
    return Landmarks(reach * np.cos(bearing), reach * np.sin(bearing),
                     np.full(len(starts), s.reflector_radius), _mean_intensity(scan, clusters),
                     np.ones(len(starts), bool), _beam_times(scan, clusters))
