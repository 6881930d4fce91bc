# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Global localization of the people tracker's robot on the known map: while its pose is unknown,
many robot particles weighed by the laser's likelihood field (tempered, at most
GLOBAL_MAX_BEAMS beams), roughened at every resampling, until they converge on a pose the map
explains; the first reading weighs a denser set of candidates."""
from __future__ import annotations

import math
import numpy as np

from fastslam_ros.core.resampling import (effective_sample_size, normalize_log_weights,
                                          systematic_resample)
from fastslam_ros.people.detection import Scan
from fastslam_ros.people.report import UpdateReport
from fastslam_ros.people.localization import (beam_endpoints, likelihood_field_log_weights,
                                              roughen, sample_free_poses, sensor_poses)

GLOBAL_TEMPERING = 0.1
"""Exponent of the likelihood field while localizing globally: the beams of one scan are far
from independent, and at full strength one reading picks a single hypothesis of thousands."""
MIN_CONVERGED_FIT = 0.6
"""Global localization converges only on a pose where at least this fraction of the beams ends
within 2 sigma_hit of a mapped obstacle; a single hypothesis that fits worse is replaced, half
of the particles drawn again over the free space."""
GLOBAL_ROUGHENING = 0.2
"""Roughening factor K (Gordon, Salmond and Smith's 0.2) of the robot particles at every
resampling while localizing globally. The first reading's candidates are too sparse to hold
one within sigma_hit of the true pose (200,000 over a 370 m^2 floor: 0.07 on average within
0.1 m and 0.01 rad), and copies of one candidate never move sideways (the odometry's noise
is along the path): unroughened, a near miss at the true place can lose to a better-aligned
candidate at a place that looks alike, and the filter converges there."""
GLOBAL_MAX_BEAMS = 60
"""Beams (of those ``beam_stride`` keeps, spread evenly over the scan) that weigh the robot
particles while localizing globally: its first reading weighs GLOBAL_CANDIDATES x
``global_particles`` poses, whose cost grows with the beams; 60 (AMCL's choice) keeps it near
a second for a laser of any resolution, and is what a 360-beam scan gives at stride 6."""
GLOBAL_CANDIDATES = 10
"""The first reading of a global localization weighs this many times global_particles poses."""
CONVERGED_UPDATES = 20
"""Readings the particles' spread must stay below converged_spread to end global
localization (2 s at 10 Hz)."""


class GlobalLocalization:
    """The part of ``PeopleTracker`` that localizes the robot while its pose is unknown."""

    def _localize_globally(self, scan: Scan, returns: np.ndarray, max_range: float
                           ) -> UpdateReport:
        """While the pose is unknown: weigh the many robot particles by the likelihood field
        (tempered by GLOBAL_TEMPERING, as the beams are not independent), resample, and end
        the phase once their spread stayed below ``converged_spread`` for CONVERGED_UPDATES
        readings at a pose the map explains (MIN_CONVERGED_FIT). The first reading weighs a
        denser set of poses (``_draw_from_first_reading``). People are tracked from then on."""
        s = self.settings
        beams = np.flatnonzero(returns)
        beams = beams[beams % s.beam_stride == 0]
        if len(beams) > GLOBAL_MAX_BEAMS:
            beams = beams[np.linspace(0, len(beams) - 1, GLOBAL_MAX_BEAMS).round().astype(int)]
        ranges, angles = scan.ranges[beams], scan.angles[beams]
        if self._first_global_reading:
            self._first_global_reading = False
            self._draw_from_first_reading(ranges, angles, max_range)
        ends = beam_endpoints(sensor_poses(self.poses, self.offset), ranges, angles)
        distances = self.grid.distance_at(ends)
        self.log_weights = self.log_weights + GLOBAL_TEMPERING * likelihood_field_log_weights(
            distances, s.sigma_hit, s.z_hit, max_range)
        self.log_weights, _ = normalize_log_weights(self.log_weights)
        weights = np.exp(self.log_weights)
        report = UpdateReport(0, 0, 0, 0, 0, effective_sample_size(weights), False, False)
        mean = weights @ self.poses[:, :2]
        spread = math.sqrt(float(weights @ np.sum((self.poses[:, :2] - mean) ** 2, axis=1)) / 2)
        fit = float(np.mean(distances[int(np.argmax(weights))] < 2.0 * s.sigma_hit)) \
            if distances.shape[1] else 0.0
        if spread < s.converged_spread and fit < MIN_CONVERGED_FIT:
            # one hypothesis left, and the map does not explain its scan: look again elsewhere
            fresh = self.rng.random(self.num_particles) < 0.5
            self.poses[fresh] = sample_free_poses(self.grid, int(fresh.sum()), self.rng)
            self.log_weights = np.full(self.num_particles, -math.log(self.num_particles))
            self._converging = 0
            return report
        self._converging = self._converging + 1 if spread < s.converged_spread else 0
        if self._converging >= CONVERGED_UPDATES:
            index = systematic_resample(weights, self.rng)
            stride = max(1, self.num_particles // s.num_particles)
            start = int(self.rng.integers(stride))
            self._allocate(self.poses[index[start::stride][:s.num_particles]])
            self.globally_localizing = False
            report.resampled = report.converged = True
        elif report.effective_sample_size < s.resample_threshold * self.num_particles:
            index = systematic_resample(weights, self.rng)
            self.poses = roughen(self.poses[index], GLOBAL_ROUGHENING, self.rng)
            self.log_weights = np.full(len(index), -math.log(len(index)))
            report.resampled = True
        return report

    def _draw_from_first_reading(self, ranges: np.ndarray, angles: np.ndarray,
                                 max_range: float) -> None:
        """Replace the uniform start by GLOBAL_CANDIDATES times as many uniform poses weighed
        by the first reading and resampled to ``global_particles``: the pose space is covered
        that much more densely once, at the cost of one weighing."""
        s = self.settings
        count = self.num_particles
        candidates = sample_free_poses(self.grid, GLOBAL_CANDIDATES * count, self.rng)
        log_weights = np.concatenate([
            GLOBAL_TEMPERING * likelihood_field_log_weights(
                self.grid.distance_at(beam_endpoints(sensor_poses(part, self.offset), ranges,
                                                     angles)),
                s.sigma_hit, s.z_hit, max_range)
            for part in np.array_split(candidates, GLOBAL_CANDIDATES)])
        weights = np.exp(normalize_log_weights(log_weights)[0])
        index = systematic_resample(weights, self.rng)
        start = int(self.rng.integers(GLOBAL_CANDIDATES))
        self.poses = roughen(candidates[index[start::GLOBAL_CANDIDATES][:count]],
                             GLOBAL_ROUGHENING, self.rng)
        self.log_weights = np.full(count, -math.log(count))
