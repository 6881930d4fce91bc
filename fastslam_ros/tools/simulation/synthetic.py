# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""In-memory synthetic worlds for the core's tests and ``fastslam-bench`` (no ROS, no bags).

A robot drives a circle through a square field of point landmarks, with the generative model of
``tools.simulation.world``: its odometry carries the odometry-model noise the filter assumes,
and its range-bearing sensor has Gaussian noise, optional missed detections and clutter.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fastslam_ros.tools.simulation.world import (RangeBearingSensor, circle_path,
                                                 odometry_with_noise, scatter_landmarks)


@dataclass
class Step:
    """One time step: odometry pose, true pose, and the observations made there (ids: the
    landmark's row, -1 for clutter)."""

    odometry: np.ndarray
    truth: np.ndarray
    ranges: np.ndarray
    bearings: np.ndarray
    ids: np.ndarray


@dataclass
class World:
    """A synthetic landmark world and the steps driven through it."""

    landmarks: np.ndarray                 # (N, 2)
    steps: list[Step] = field(default_factory=list)

    @property
    def num_observations(self) -> int:
        return sum(len(s.ranges) for s in self.steps)


def make_world(seed: int = 0, num_landmarks: int = 40, extent: float = 40.0,
               num_steps: int = 300, max_range: float = 12.0,
               sigma_range: float = 0.1, sigma_bearing: float = 0.02,
               odometry_noise: tuple[float, float, float] = (0.01, 0.05, 0.01),
               detection_probability: float = 1.0, clutter_per_step: float = 0.0,
               laps: float = 1.0, min_separation: float = 2.0) -> World:
    """``num_steps`` steps ``laps`` times round a circle of radius extent/3 about the centre of
    a square landmark field ``extent`` m wide, one reading per step.

    Odometry follows the odometry model: each step's (rot1, trans, rot2) is corrupted by
    N(0, odometry_noise[0]) rad, a relative N(0, odometry_noise[1]) scale error and
    N(0, odometry_noise[2]) rad. The landmarks, the odometry noise and the sensor noise have
    their own random streams (from ``seed``): changing the sensor leaves the path and the
    landmarks as they were.
    """
    landmark_rng, odometry_rng, sensor_rng = (np.random.default_rng(child) for child in
                                              np.random.SeedSequence(seed).spawn(3))
    half = 0.5 * extent
    landmarks = scatter_landmarks(landmark_rng, num_landmarks, (-half, -half), (half, half),
                                  min_separation)
    truth = circle_path(extent / 3.0, num_steps, laps)
    odometry = odometry_with_noise(truth, odometry_noise, odometry_rng)
    sensor = RangeBearingSensor(max_range, sigma_range, sigma_bearing, detection_probability,
                                clutter_per_step, clutter_spread="range")
    steps = []
    for pose, odometry_pose in zip(truth[1:], odometry[1:]):
        reading = sensor.observe(pose, landmarks, sensor_rng)
        steps.append(Step(odometry_pose.copy(), pose.copy(), reading.ranges, reading.bearings,
                          reading.labels.astype(np.int64)))
    return World(landmarks, steps)
