# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Localization on a fixed map: find the pose again from one reading when the filter is lost.

A particle filter whose particles all sit away from the true pose cannot come back by itself:
observations that match no landmark only weigh p0. Sensor resetting (Lenser and Veloso, 2000)
draws particles at poses computed from the current reading instead. Here a pose is found by
matching the reading's geometry to the map: every pair of observed points (robot frame) is
matched to the pairs of map landmarks at the same distance, each match gives one rigid pose,
and the pose under which most observations lie near a landmark wins (refined by least squares
over those). All pairs and candidates are scored at once, as arrays.
"""
from __future__ import annotations

import math

import numpy as np

from .geometry import rigid_fit, wrap_angle
from .observation import MIN_OBSERVATION_RANGE

MIN_PAIR_DISTANCE = 2.0
"""Observed pairs closer than this (m) give too uncertain a heading to propose a pose."""
MAX_CANDIDATES = 2000
"""Candidate poses scored per reading at most (the closest distance matches first)."""
MAX_PAIR_POINTS = 12
"""Observed points (spread evenly over the reading) whose pairs propose poses: 66 pairs at
most, so the pair matching stays (66, N, N) whatever the reading holds."""
MAX_SCORED_POINTS = 40
"""Observed points (spread evenly over the reading) that score the candidates."""
SCORE_CHUNK = 200
"""Candidates scored at once: (200, 40, N) distances bound the memory of a search."""
RELOCALIZATION_RADIUS = 10.0
"""Metres beyond the sensor's reach around the best particle within which the map's landmarks
are matched to a reading when the filter is lost (``FastSLAM._relocalize``)."""
RELOCALIZATION_RETRY = 1.0
"""Seconds after a pose search that found nothing before the next one (a search over a
reading costs tens of milliseconds)."""
MAX_RELOCALIZATION_LANDMARKS = 150
"""Landmarks (the nearest to the best particle) a pose search matches a reading against: the
search's pair matching grows with their square."""
MIN_RELOCALIZATION_INLIERS = 3
"""Observations a pose found from one reading must put near landmarks (two pin any pair)."""


def world_points(pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(K, 2) robot-frame points in the world frame from ``pose`` (3,)."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return points @ np.array([[c, s], [-s, c]]) + pose[:2]


def explained(points: np.ndarray, landmarks: np.ndarray, gate: float) -> np.ndarray:
    """(..., K) which world points (..., K, 2) lie within ``gate`` (m) of some landmark (N, 2)."""
    if len(landmarks) == 0:
        return np.zeros(points.shape[:-1], bool)
    offsets = points[..., None, :] - landmarks
    return (np.einsum("...i,...i->...", offsets, offsets) <= gate * gate).any(axis=-1)


def find_pose(points: np.ndarray, landmarks: np.ndarray, tolerance: float
              ) -> tuple[np.ndarray, int]:
    """The pose (3,) that puts most of ``points`` (K, 2, robot frame) within ``tolerance`` (m)
    of ``landmarks`` (N, 2), and how many it puts there (0 and a zero pose: no candidate).

    Candidates come from observed pairs (a, b) and landmark pairs (i, j), i != j, whose
    distances agree within ``tolerance`` (a and b among ``MAX_PAIR_POINTS`` of the points,
    scored on ``MAX_SCORED_POINTS`` of them): the rotation takes b - a onto j - i and the
    translation a onto i. Ties in the count go to the smaller sum of squared distances. The
    winner is refined by least squares over its matched points."""
    pose, inliers, _ = find_pose_and_rival(points, landmarks, tolerance, math.inf)
    return pose, inliers


def find_pose_and_rival(points: np.ndarray, landmarks: np.ndarray, tolerance: float,
                        distinct: float) -> tuple[np.ndarray, int, int]:
    """``find_pose``, and the most points any candidate pose farther than ``distinct`` (m)
    from the winner puts near landmarks (the distance between two poses: their positions'
    plus their headings' over the points' spread): a rival as good as the winner makes the
    match ambiguous."""
    if len(points) < 2 or len(landmarks) < 2:
        return np.zeros(3), 0, 0
    pairing = _spread(points, MAX_PAIR_POINTS)
    a, b = np.triu_indices(len(pairing), 1)
    observed = pairing[b] - pairing[a]
    observed_length = np.hypot(observed[:, 0], observed[:, 1])
    keep = observed_length >= MIN_PAIR_DISTANCE
    a, b, observed, observed_length = a[keep], b[keep], observed[keep], observed_length[keep]
    mapped = landmarks[None, :] - landmarks[:, None]                        # (N, N, 2): j - i
    mapped_length = np.hypot(mapped[..., 0], mapped[..., 1])
    mismatch = np.abs(observed_length[:, None, None] - mapped_length)      # (P, N, N)
    diagonal = np.arange(len(landmarks))
    mismatch[:, diagonal, diagonal] = np.inf                               # no pair (i, i)
    pair, i, j = (mismatch <= tolerance).nonzero()
    if len(pair) == 0:
        return np.zeros(3), 0, 0
    if len(pair) > MAX_CANDIDATES:
        order = np.argsort(mismatch[pair, i, j], kind="stable")[:MAX_CANDIDATES]
        pair, i, j = pair[order], i[order], j[order]
    yaw = wrap_angle(np.arctan2(mapped[i, j, 1], mapped[i, j, 0])
                     - np.arctan2(observed[pair, 1], observed[pair, 0]))
    c, s = np.cos(yaw), np.sin(yaw)
    first = pairing[a[pair]]
    x = landmarks[i, 0] - (c * first[:, 0] - s * first[:, 1])
    y = landmarks[i, 1] - (s * first[:, 0] + c * first[:, 1])
    scoring = _spread(points, MAX_SCORED_POINTS)
    squared = np.concatenate([_nearest_squared(scoring, landmarks, x[k:k + SCORE_CHUNK],
                                               y[k:k + SCORE_CHUNK], c[k:k + SCORE_CHUNK],
                                               s[k:k + SCORE_CHUNK])
                              for k in range(0, len(x), SCORE_CHUNK)])       # (C, K')
    inside = squared <= tolerance * tolerance
    inliers = inside.sum(axis=1)
    cost = np.where(inside, squared, 0.0).sum(axis=1)
    best = int(np.lexsort((cost, -inliers))[0])
    spread = max(float(np.hypot(scoring[:, 0], scoring[:, 1]).max()), tolerance)
    apart = (np.hypot(x - x[best], y - y[best])
             + spread * np.abs(wrap_angle(yaw - yaw[best]))) > distinct
    rival = int(inliers[apart].max(initial=0))
    pose = np.array([x[best], y[best], yaw[best]])
    matched = inside[best]
    world = world_points(pose, scoring[matched])
    nearest = landmarks[np.argmin(((world[:, None] - landmarks) ** 2).sum(axis=2), axis=1)]
    pose = _fit(scoring[matched], nearest, pose)
    return pose, int(explained(world_points(pose, points), landmarks, tolerance).sum()), rival


def _spread(points: np.ndarray, limit: int) -> np.ndarray:
    """At most ``limit`` of the points (K, 2), evenly spread over their order."""
    if len(points) <= limit:
        return points
    return points[np.linspace(0, len(points) - 1, limit).round().astype(int)]


def _nearest_squared(points, landmarks, x, y, c, s) -> np.ndarray:
    """(C, K) squared distance of every point (K, 2) under every candidate pose (x, y and the
    cosine and sine of the heading, (C,)) to its nearest landmark (N, 2)."""
    px = c[:, None] * points[:, 0] - s[:, None] * points[:, 1] + x[:, None]
    py = s[:, None] * points[:, 0] + c[:, None] * points[:, 1] + y[:, None]
    return ((px[..., None] - landmarks[:, 0]) ** 2
            + (py[..., None] - landmarks[:, 1]) ** 2).min(axis=2)


def _fit(points: np.ndarray, targets: np.ndarray, guess: np.ndarray) -> np.ndarray:
    """The rigid pose taking ``points`` (robot frame) onto ``targets`` (world) in least
    squares (closed form); ``guess`` when fewer than two points."""
    if len(points) < 2:
        return guess
    yaw, translation = rigid_fit(points, targets)
    return np.array([translation[0], translation[1], float(yaw)])


class Relocalizing:
    """Localization on a fixed map, the part of ``FastSLAM`` that finds its pose again when lost."""

    def _relocalize(self, ranges: np.ndarray, bearings: np.ndarray, stamp: float) -> None:
        """Localization on a fixed map (sensor resetting). The best particle is lost while at
        most half of each reading's observations lie within ``relocalization_gate`` of a
        landmark seen from it. While lost, once per ``RELOCALIZATION_RETRY`` s, the pose that
        explains more of them is searched (``relocalization.find_pose``, over the landmarks
        within the sensor's reach plus ``RELOCALIZATION_RADIUS``, the nearest
        ``MAX_RELOCALIZATION_LANDMARKS``); a pose that explains more than half and at least
        ``MIN_RELOCALIZATION_INLIERS`` is taken once the loss has lasted
        ``relocalization_delay`` s, or earlier once it lies ``relocalization_gate`` farther
        from the best particle than the closest such pose of this loss (the filter is drifting
        away from the map, not finding it by itself), or at once while the map has not been
        found since an ``initialize_pose`` (a pose a user guessed, not a filter that may find
        the map by itself). Taking it redraws the
        ``relocalization_fraction`` lightest particles (among equal weights, as after
        resampling, the first ones) around it (weights uniform, as after resampling)."""
        usable = (np.isfinite(ranges) & np.isfinite(bearings)
                  & (ranges >= MIN_OBSERVATION_RANGE))
        count = int(usable.sum())
        if count < MIN_RELOCALIZATION_INLIERS or self._seed is None:
            return
        ranges, bearings = ranges[usable], bearings[usable]
        angle = bearings + self.offset.yaw
        points = np.column_stack([self.offset.x + ranges * np.cos(angle),
                                  self.offset.y + ranges * np.sin(angle)])
        pose = self.poses[self._best]
        means = self._seed[0]
        reach = self._reach(ranges) + RELOCALIZATION_RADIUS
        squared = ((means - pose[:2]) ** 2).sum(axis=1)
        near = means[squared <= reach * reach]
        if len(near) > MAX_RELOCALIZATION_LANDMARKS:
            near = means[np.argsort(squared, kind="stable")[:MAX_RELOCALIZATION_LANDMARKS]]
        gate = self.config.relocalization_gate
        hits = int(explained(world_points(pose, points), near, gate).sum())
        if 2 * hits > count:
            self._lost_since = None
            self._placed = False
            return
        if self._lost_since is None:
            self._lost_since, self._searched, self._closest = stamp, -math.inf, math.inf
        if stamp - self._searched < RELOCALIZATION_RETRY:
            # A search costs tens of milliseconds: one per RELOCALIZATION_RETRY s.
            return
        self._searched = stamp
        found, inliers = find_pose(points, near, gate)
        if 2 * inliers <= count or inliers < max(MIN_RELOCALIZATION_INLIERS, hits + 1):
            # Nothing found (e.g. where the map has no landmarks).
            self._closest = math.inf
            return
        apart = float(np.hypot(*(found[:2] - pose[:2])))
        self._closest = min(self._closest, apart)
        if (not self._placed and stamp - self._lost_since < self.config.relocalization_delay
                and apart < self._closest + gate):
            # Within the delay the filter may find the map by itself; once the pose the
            # readings give has drifted a gate farther from it than it was, it will not.
            return
        redrawn = np.argsort(self.log_weights, kind="stable")[
            :max(1, round(self.config.relocalization_fraction * self.num_particles))]
        spread = np.array([0.5 * gate, 0.5 * gate, gate / max(float(ranges.max()), gate)])
        poses = found + spread * self.rng.standard_normal((len(redrawn), 3))
        poses[:, 2] = wrap_angle(poses[:, 2])
        self.poses[redrawn] = poses
        self.log_weights = np.full(self.num_particles, -np.log(self.num_particles))
        self._best = int(redrawn[0])
        self._lost_since = None
        self._placed = False
        self.num_relocalizations += 1
