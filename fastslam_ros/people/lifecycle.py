# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The tracker's map and pose lifecycle (ROS-free): a changed map that keeps the pose, the
bounds of an initial pose, and the watch that tells when the tracker is lost.

A robot that localizes on a map must not jump when the map is sent again or edited: a map
equal to the current one changes nothing, and a changed one keeps the robot particles that
are still in free space (with their people, but those no longer in free space). A pose given
outside the map, or with a spread larger than the map, is no pose; one that puts the robot
in a wall is caught by ``LostWatch``, which also catches a tracker that drifted off: when the
particles stand in walls or the scans no longer fit the map for LOST_READINGS readings in a
row, the node localizes globally again.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fastslam_ros.core.resampling import normalize_log_weights, systematic_resample
from fastslam_ros.people.conditional_filter import PeopleTracker
from fastslam_ros.people.detection import Scan
from fastslam_ros.people.grid import OccupancyMap
from fastslam_ros.people.localization import beam_endpoints, sensor_poses
from fastslam_ros.people.particle_stats import particle_means

LOST_READINGS = 20
"""Readings in a row (2 s at 10 Hz) that must look lost before the tracker relocalizes."""
LOST_FIT = 0.3
"""A reading looks lost when fewer than this fraction of its returns end, seen from the best
particle, within 2 sigma_hit of a mapped obstacle (a localized robot: about 0.9 with people
in view; global localization asks 0.6 to converge) ..."""
LOST_FREE_WEIGHT = 0.5
"""... or when less than this share of the particles' weight stands in free cells."""


def same_map(current: OccupancyMap | None, new: OccupancyMap) -> bool:
    """Whether ``new`` is ``current`` again (same cells, resolution, origin and field)."""
    return (current is not None and current.shape == new.shape
            and current.resolution == new.resolution and current.origin == new.origin
            and current.max_distance == new.max_distance
            and np.array_equal(current.occupied, new.occupied)
            and np.array_equal(current.free, new.free))


@dataclass
class MapChange:
    """What installing a changed map did."""

    kept_pose: bool
    """The pose estimate was kept (False: the robot is localized globally on the new map)."""
    people_removed: int
    """People of the best robot particle removed as no longer in free space."""


def change_map(tracker: PeopleTracker, grid: OccupancyMap) -> MapChange:
    """Install a changed ``grid`` (with a free cell) keeping the pose estimate: the robot
    particles in free cells of the new map are kept (all of them, weights unchanged, when all
    are; else resampled from those by weight) with their people, but the people whose mean is
    no longer in a free cell. With no particle in free space, or while localizing globally,
    the robot is localized globally on the new map."""
    if tracker.grid is None or tracker.globally_localizing:
        tracker.set_map(grid)
        return MapChange(False, 0)
    free = grid.is_free(tracker.poses[:, :2])
    if not free.any():
        tracker.set_map(grid)
        return MapChange(False, 0)
    tracker.grid = grid
    if not free.all():
        log_weights = np.where(free, tracker.log_weights, -np.inf)
        weights = np.exp(normalize_log_weights(log_weights)[0])
        tracker._gather(systematic_resample(weights, tracker.rng))
    m, n = np.nonzero(tracker.alive)
    gone = ~grid.is_free(particle_means(tracker.people[m, n]))
    removed = int(np.sum(m[gone] == tracker.best_index))
    m, n = m[gone], n[gone]
    tracker.alive[m, n] = tracker.confirmed[m, n] = False
    tracker.keys[m, n] = -1
    return MapChange(True, removed)


def initial_pose_problem(grid: OccupancyMap, pose: np.ndarray, covariance: np.ndarray
                         ) -> tuple[str, str] | None:
    """Why an initial pose (x, y, yaw) with ``covariance`` (3, 3) cannot place the robot on
    ``grid``: (counter reason, message), or None when it can. Outside the grid, or with a
    position standard deviation beyond the grid's diagonal or a heading one beyond a turn,
    it says nothing about where the robot is."""
    x0, x1, y0, y1 = grid.extent
    if not (x0 <= pose[0] < x1 and y0 <= pose[1] < y1):
        return ("initialpose_off_map", f"initialpose ({pose[0]:.6g}, {pose[1]:.6g}) m is "
                                       f"outside the map [{x0:g}, {x1:g}] x [{y0:g}, {y1:g}]")
    diagonal = math.hypot(x1 - x0, y1 - y0)
    if max(covariance[0, 0], covariance[1, 1]) > diagonal ** 2 \
            or covariance[2, 2] > (2.0 * math.pi) ** 2:
        return ("initialpose_covariance", f"initialpose covariance diagonal "
                f"{np.diag(covariance).tolist()} is wider than the map ({diagonal:.3g} m) "
                "or a turn")
    return None


def scan_fit(tracker: PeopleTracker, scan: Scan) -> float:
    """Fraction of the scan's returns that end, seen from the best robot particle, within
    2 sigma_hit of a mapped obstacle (1 for a scan with no return: no evidence)."""
    s = tracker.settings
    returns = np.flatnonzero(scan.returns(s.min_range, s.max_range))
    if len(returns) == 0:
        return 1.0
    sensor = sensor_poses(tracker.poses[tracker.best_index][None], tracker.offset)
    ends = beam_endpoints(sensor, scan.ranges[returns], scan.angles[returns])
    return float(np.mean(tracker.grid.distance_at(ends) < 2.0 * s.sigma_hit))


class LostWatch:
    """Tells when the tracker is lost: LOST_READINGS readings in a row in which the scan
    does not fit the map (LOST_FIT) or the particles stand outside free space
    (LOST_FREE_WEIGHT). Global localization is never lost (it is looking)."""

    def __init__(self) -> None:
        self.count = 0

    def clear(self) -> None:
        self.count = 0

    def lost(self, tracker: PeopleTracker, scan: Scan) -> bool:
        """Whether the tracker is lost after it used ``scan``."""
        if tracker.globally_localizing:
            self.count = 0
            return False
        weights = np.exp(normalize_log_weights(tracker.log_weights)[0])
        in_free = float(weights @ tracker.grid.is_free(tracker.poses[:, :2]))
        bad = in_free < LOST_FREE_WEIGHT or scan_fit(tracker, scan) < LOST_FIT
        self.count = self.count + 1 if bad else 0
        return self.count >= LOST_READINGS


def repair(tracker: PeopleTracker) -> bool:
    """Repair a non-finite state left by an update (the SLAM core's ``check_state`` rule);
    True if it had to. Inputs are gated before they get here, so this is the last line of
    defence: a robot particle whose pose, weight or live people are not finite is replaced
    by a copy of a finite one (weights uniform, as after resampling); with none finite the
    robot is localized globally."""
    count = tracker.num_particles
    bad = ~np.isfinite(tracker.poses).all(axis=1) | np.isnan(tracker.log_weights)
    m, n = np.nonzero(tracker.alive)
    bad[m[~np.isfinite(tracker.people[m, n]).all(axis=(1, 2))]] = True
    if not bad.any():
        return False
    good = np.flatnonzero(~bad)
    if len(good) == 0:
        tracker.reset()
        return True
    index = np.arange(count)
    index[bad] = good[np.arange(int(bad.sum())) % len(good)]
    tracker._gather(index)
    return True
