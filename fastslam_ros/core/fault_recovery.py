# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Recovery from an odometry fault (``fault_recovery_matches``).

A robot whose odometry integrates its commanded velocities reports turns it did not make (a
wheel stuck, a bumper pressed). Every particle turns with the odometry, so afterwards the
landmarks in view lie far outside their association gates, at any angle about the robot, and
every particle maps them a second time in a rotated frame. The loop closure
(``loop_closure``) cannot pair them: it allows a drift that grows with the distance
travelled and a small heading error, and these landmarks were seen moments ago.

The rotated copies keep the shape of the landmarks they duplicate. So, at most once per
``SEARCH_RETRY`` s of data, the reported particle's youngest confirmed landmarks (the k, 2k and
4k most recently created, within ``YOUNG_RANGES`` sensor ranges of travel: when the fault
happened is not known) are matched to its confirmed landmarks created before them as one rigid
body with any rotation (``relocalization.find_pose_and_rival``, the pair-distance search that
localization uses on a reading), among the older landmarks within two sensor ranges of the
robot (the copies are of landmarks in view). A young landmark is a copy of the old one it lands
on within ``fault_recovery_gate`` only if that old one was not observed after the copy was
created (the robot would have seen it where it is; ``landmark_clock``). The match is taken when
at least k young landmarks, and half of them, are copies, no distinct pose (``DISTINCT_POSE``)
puts as many onto old landmarks, the match moves them by more than the gate (nearer, they are
neighbours, not copies), and it moves the robot no farther than a turn of its angle about a
point of the recent path would (the turn times ``YOUNG_RANGES`` sensor ranges, plus the gate;
without these two bounds, new territory that repeats the shape of old landmarks moved the
default world's robot by tens of metres). Then the particle's pose moves by the rigid motion,
the young landmarks created since the first copy move with it, the copies are removed, and
every particle takes the corrected one (they all carry the same fault). The next readings
associate the old landmarks as before the fault.

Measured (docs/benchmarks.md, "Odometry faults"): it brings the faults scenario back to its
map and changes nothing in the room, default and clutter worlds; on MRCLAM's sparse readings
(one or two landmarks at a time, 15 in all) the few landmarks mapped between faults match the
wrong way, and among Victoria Park's hundreds of trees three young ones find wrong matches, so
it is off by default and in ``config/mrclam.yaml``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .geometry import wrap_angle
from .existence import existence_logodds
from .landmark_clock import LandmarkClock
from .landmark_store import WorkingSet
from .loop_closure import rotate_cov
from .relocalization import (MAX_RELOCALIZATION_LANDMARKS, find_pose_and_rival,
                             world_points)

YOUNG_RANGES = 2.0
"""A landmark created within this many ``max_range`` of travel is young: it may be a copy
mapped after a fault."""
DISTINCT_POSE = 1.0
"""Distance (m) between two robot poses (position plus heading over the landmarks' spread)
beyond which they are distinct explanations: the match is taken only when no distinct pose
puts as many young landmarks onto old ones."""
SEARCH_RETRY = 1.0
"""Seconds of data between two searches (a search costs milliseconds to tens of them)."""


@dataclass
class Correction:
    """A rigid correction of the reported particle: rotation (rad) about ``pivot`` (the
    particle's position), then ``shift`` (m); the landmark keys that move with it and those
    removed as copies of older landmarks."""

    rotation: float
    pivot: np.ndarray
    shift: np.ndarray
    moved_keys: np.ndarray
    copy_keys: np.ndarray

    def apply(self, points: np.ndarray) -> np.ndarray:
        """(K, 2) world points moved by the correction: seen from the pivot, placed from the
        corrected pose (``relocalization.world_points``)."""
        return world_points(np.append(self.pivot + self.shift, self.rotation),
                            points - self.pivot)


class FaultRecovery:
    """The search for a rigidly moved copy of the map (module docstring)."""

    def __init__(self, matches: int, gate: float, min_existence: float, max_range: float,
                 clock: LandmarkClock) -> None:
        self.matches = matches
        self.gate = gate
        self.min_logodds = existence_logodds(min_existence)
        self.young_travel = YOUNG_RANGES * max_range
        self.max_range = max_range
        self.clock = clock
        """Creation and observation times of the landmark keys (shared, ``FastSLAM``)."""
        self.num_recoveries = 0
        """Corrections made so far."""
        self._searched = -math.inf

    def due(self, stamp: float) -> bool:
        """Whether a search is due at ``stamp``: ``SEARCH_RETRY`` s of data since the last one
        (or time went back); the caller reads the particle's map only then."""
        return not (stamp - self._searched < SEARCH_RETRY and stamp >= self._searched)

    def search(self, pose: np.ndarray, landmarks: tuple[np.ndarray, ...],
               stamp: float) -> Correction | None:
        """The correction the particle at ``pose`` (3,) with the map ``landmarks`` (mean,
        packed cov, log-odds, label, key: ``FastSLAM.particle_map``) needs, or None (also
        when no search is due). The young landmarks are the k, 2k and 4k most recently
        created (the fault's time is not known), each set matched to the confirmed landmarks
        created before it."""
        if not self.due(stamp):
            return None
        self._searched = stamp
        mean, _, logodds, _, key = landmarks
        confirmed = logodds >= self.min_logodds
        created = self.clock.created[np.maximum(key, 0)]
        travelled = self.clock.travelled
        recent = np.sort(created[confirmed & (travelled - created <= self.young_travel)])
        for count in (self.matches, 2 * self.matches, 4 * self.matches):
            if count > len(recent):
                break
            since = recent[-count]
            correction = self._match(pose, mean, key, confirmed & (created >= since),
                                     confirmed & (created < since))
            if correction is not None:
                self.num_recoveries += 1
                return correction
        return None

    def _match(self, pose: np.ndarray, mean: np.ndarray, key: np.ndarray, young: np.ndarray,
               old: np.ndarray) -> Correction | None:
        """The correction that puts the ``young`` landmarks onto ``old`` ones within two
        sensor ranges and not observed since (copies), when at least k and half of them are
        copies, no distinct motion puts as many near old landmarks, the motion moves them by
        more than the gate and the robot no farther than its turn about the recent path
        would; else None."""
        count = int(young.sum())
        if not old.any():
            return None
        # The copies are of landmarks the robot sees now: their originals lie within the
        # sensor's range of it (its position is off by less than the young landmarks' spread).
        near = old & (((mean - pose[:2]) ** 2).sum(axis=1) <= (2.0 * self.max_range) ** 2)
        old_means, old_keys = mean[near], key[near]
        if len(old_means) < 2:
            return None
        if len(old_means) > MAX_RELOCALIZATION_LANDMARKS:
            nearest = np.argsort(((old_means - pose[:2]) ** 2).sum(axis=1), kind="stable")[
                :MAX_RELOCALIZATION_LANDMARKS]
            old_means, old_keys = old_means[nearest], old_keys[nearest]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        robot_frame = (mean[young] - pose[:2]) @ np.array([[c, -s], [s, c]])
        found, inliers, rival = find_pose_and_rival(robot_frame, old_means, self.gate,
                                                    DISTINCT_POSE)
        if inliers < max(self.matches, (count + 1) // 2) or rival >= inliers:
            return None
        moved_to = world_points(found, robot_frame)
        squared = ((moved_to[:, None] - old_means) ** 2).sum(axis=2)
        nearest = squared.argmin(axis=1)
        young_keys = key[young]
        young_created = self.clock.created[young_keys]
        copies = ((squared[np.arange(count), nearest] <= self.gate * self.gate)
                  & (self.clock.seen[old_keys[nearest]] <= young_created))
        if copies.sum() < max(self.matches, (count + 1) // 2):
            return None
        if np.median(np.hypot(*(moved_to - mean[young]).T)[copies]) <= self.gate:
            return None       # young landmarks next to old ones: neighbours, not copies
        if np.hypot(*(found[:2] - pose[:2])) > abs(wrap_angle(found[2] - pose[2])) * (
                self.young_travel) + self.gate:
            return None       # farther than a turn about a point of the recent path moves it
        since = young_created[copies].min()
        return Correction(float(wrap_angle(found[2] - pose[2])), pose[:2].copy(),
                          found[:2] - pose[:2],
                          young_keys[~copies & (young_created >= since)], young_keys[copies])


def correct_map(ws: WorkingSet, row: int, correction: Correction) -> None:
    """Apply ``correction`` to particle ``row``'s entries of a whole-map working set
    (``LandmarkStore.gather_maps``): move the keys that move, remove the copies."""
    valid = ws.valid[row]
    key = ws.key[row]
    moved = valid & np.isin(key, correction.moved_keys)
    copy = valid & np.isin(key, correction.copy_keys)
    ws.mean[row, moved] = correction.apply(ws.mean[row, moved])
    ws.cov[row, moved] = rotate_cov(ws.cov[row, moved], math.cos(correction.rotation),
                                    math.sin(correction.rotation))
    ws.valid[row] = valid & ~copy
    ws.dirty[row] |= moved | copy
