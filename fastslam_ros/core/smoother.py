# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The estimate at the time from a least squares over the reported particle's path and map.

A particle's pose fits its own map, and its map was built from poses that had drifted: nothing
moves a landmark once the robot has left it, so the reported pose carries the map's errors and
jumps when the reported particle changes. Every ``smoothing_period`` seconds of data
``OnlineSmoother`` solves the map refinement's least squares (``map_refinement.refine``: the
logged odometry and observations, the reported particle's associations) and keeps the solved
pose of the latest reading; between solves it follows the particles' mean motion from there
(each particle's pose now against its pose at the solve: the odometry as the filter's
observations corrected it, which late in a long log, with solves tens of seconds apart, keeps
the estimate off the odometry's drift). The solve's
frame is the one the filter started in (the log's origin), so solves agree with each other
whichever particle is reported, and the solve's map is the one reported with that pose. The
filter itself is unchanged: the particles and their maps are the filter's.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .geometry import compose, relative_pose, wrap_angle
from .map_refinement import Marginals, Solution, odometry_covariances, refine

SOLVE_POSES = 1024
"""Poses a solve solves for at most (keyframes beyond; ``map_refinement.MAX_SOLVE_POSES``):
the solves repeat all run long, and the readings between keyframes follow their odometry."""
SOLVE_SPACING = 1.5e-4
"""Seconds of data between two solves per logged observation, at least (``smoothing_period``
when more): a solve's cost grows with the log (``fastslam-sim --scenario large``: 0.2 s of CPU
at 25,000 observations, 1.2 s at 60,000), so the solves space out as the log grows and take
about a sixth of real time on one core or less, however long the run; counted in observations,
not in CPU time, so that a replay gives the same estimate on any machine."""


class OnlineSmoother:
    """The latest solved pose, and every particle's pose and the odometry it was solved at."""

    def __init__(self, period: float) -> None:
        self.period = float(period)
        """Seconds of data between solves."""
        self.solves = 0
        """Solves that gave a pose."""
        self.failures = 0
        """Solves that gave none (no logged observation matched, a degenerate solution); a
        solve before the first confirmed landmark is no failure."""
        self.clear()

    def clear(self) -> None:
        """Forget the solution (the filter was reset or given a pose)."""
        self._solved: np.ndarray | None = None
        self._solution: Solution | None = None
        self._map = None
        self._marginals: Marginals | None = None
        self._solved_odometry = np.zeros(3)
        self._anchors = np.zeros((0, 3))
        self._covariance = np.zeros((3, 3))
        self._last = -math.inf
        self._interval = self.period

    @property
    def landmark_map(self):
        """The latest solve's confirmed map (a ``LandmarkMap``, the frame of ``pose``) with the
        landmarks' marginal covariances, which hold the path's uncertainty too; solved on the
        first read after a solve (a read costs about as much as a solve; the map is published
        at ``markers_rate``, the solves come every ``smoothing_period``)."""
        if self._marginals is not None:
            self._map = dataclasses.replace(
                self._map, covariances=self._marginals.landmark_covariances(self._map.covariances))
            self._marginals = None
        return self._map

    def due(self, stamp: float) -> bool:
        """A solve is due: ``smoothing_period``, or ``SOLVE_SPACING`` per logged observation at
        the last solve, seconds of data since it."""
        return stamp - self._last >= self._interval

    def solve(self, slam, stamp: float) -> None:
        """Refine the reported particle's path and confirmed map over ``slam.readings`` and keep
        the latest reading's solved pose; a failed solve keeps the previous one."""
        self._last = stamp
        config = slam.config
        log = slam.readings
        self._interval = max(self.period, SOLVE_SPACING * log.num_observations)
        landmark_map = slam.best_map(config.map_min_existence)
        if len(landmark_map) == 0 or len(log) < 2:
            return
        path_stamps, path = slam.best_path()
        try:
            refined, report = refine(log, path_stamps, path, landmark_map, config,
                                     known_ids=config.association == "known",
                                     start=self._solution, max_solve_poses=SOLVE_POSES,
                                     max_rounds=1, latest_covariance=True)
        except (ValueError, RuntimeError, np.linalg.LinAlgError):  # RuntimeError: a singular
            self.failures += 1                                       # factorization (SuperLU)
            return
        latest = report.solution.poses[-1]
        if not np.isfinite(latest).all():
            self.failures += 1
            return
        self._solution, self._map, self._marginals = report.solution, refined, report.marginals
        self._covariance = report.latest_covariance
        # No motion has come since the reading just logged: the log's odometry is its own.
        self._solved, self._solved_odometry = latest, log.odometry_pose
        self._anchors = slam.particle_poses()
        self.solves += 1

    def resample(self, indices: np.ndarray) -> None:
        """Each particle takes the solve-time pose of the particle it copies (resampling)."""
        if len(self._anchors):
            self._anchors = self._anchors[indices]

    def _moved(self, particle: int, poses: np.ndarray) -> np.ndarray:
        """(n, 3) the solved pose moved as ``particle`` moved from the solve to ``poses``."""
        return compose(np.broadcast_to(self._solved, poses.shape),
                       relative_pose(self._anchors[particle][None], poses))

    def path(self, slam) -> tuple[np.ndarray, np.ndarray] | None:
        """(stamps (T,), poses (T, 3)): the latest solve's poses of the readings it solved,
        then the reported particle's poses since, moved with it and bent linearly in time to
        end at ``pose`` (the published path ends where the published pose is; None before the
        first solve)."""
        if self._solution is None:
            return None
        stamps, poses = slam.best_path()
        solved_at = self._solution.stamps[-1]
        later = stamps > solved_at
        tail = self._moved(slam.best_index(), poses[later])
        if len(tail):
            gap = self.pose(slam) - tail[-1]
            gap[2] = wrap_angle(gap[2])
            share = (stamps[later] - solved_at) / (stamps[later][-1] - solved_at)
            tail = tail + share[:, None] * gap
            tail[:, 2] = wrap_angle(tail[:, 2])
        return (np.concatenate([self._solution.stamps, stamps[later]]),
                np.concatenate([self._solution.poses, tail]))

    def covariance(self, odometry_now: np.ndarray, config) -> np.ndarray | None:
        """(3, 3) the pose's covariance now: the solved pose's marginal (relative to the first
        pose) plus the odometry's noise since, turned into the map frame (the heading's
        growing lever on the position left out: the solves are seconds apart); None before
        the first solve."""
        if self._solved is None:
            return None
        step = relative_pose(self._solved_odometry[None], np.asarray(odometry_now)[None])
        noise = odometry_covariances(step, config)[0]
        c, s = math.cos(self._solved[2]), math.sin(self._solved[2])
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return self._covariance + turn @ noise @ turn.T

    def pose(self, slam) -> np.ndarray | None:
        """(3,) the pose now: the latest solved pose moved by the particles' weighted mean
        motion since the solve, each particle's from its own pose then (the mean, not one
        particle's, as a FastSLAM 2.0 particle's pose carries its proposal's sampling
        noise); None before the first solve."""
        if self._solved is None:
            return None
        motion = relative_pose(self._anchors, slam.particle_poses())
        weights = slam.weights() / slam.weights().sum()
        heading = math.atan2(weights @ np.sin(motion[:, 2]), weights @ np.cos(motion[:, 2]))
        mean = np.append(weights @ motion[:, :2], heading)
        return compose(self._solved[None], mean[None])[0]
