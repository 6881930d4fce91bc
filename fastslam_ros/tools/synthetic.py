"""In-memory synthetic worlds for the core's tests and ``fastslam-bench`` (no ROS, no bags).

A unicycle robot drives a closed loop through a field of point landmarks; odometry is the true
motion corrupted with the odometry noise model, observations are range-bearing with Gaussian
noise, optional missed detections and clutter.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fastslam_ros.core.geometry import compose, relative_pose, wrap_angle


@dataclass
class Step:
    """One time step: odometry pose, true pose, and the observations made there."""

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
               num_steps: int = 300, speed: float = 1.0, max_range: float = 12.0,
               sigma_range: float = 0.1, sigma_bearing: float = 0.02,
               odometry_noise: tuple[float, float, float] = (0.01, 0.05, 0.01),
               detection_probability: float = 1.0, clutter_per_step: float = 0.0,
               laps: float = 1.0, min_separation: float = 2.0) -> World:
    """A loop of radius ~extent/3 around the centre of a square landmark field.

    Odometry follows the odometry model: each step's (rot1, trans, rot2) is corrupted by
    N(0, odometry_noise[0]) rad, a relative N(0, odometry_noise[1]) scale error and
    N(0, odometry_noise[2]) rad.
    """
    rng = np.random.default_rng(seed)
    landmarks = _separated_points(rng, num_landmarks, extent, min_separation)
    radius = extent / 3.0
    angle_step = 2.0 * np.pi * laps / num_steps
    truth = np.array([radius, 0.0, np.pi / 2])
    odometry = truth.copy()
    world = World(landmarks)
    for _ in range(num_steps):
        true_delta = np.array([2 * radius * np.sin(angle_step / 2) * np.cos(angle_step / 2),
                               2 * radius * np.sin(angle_step / 2) * np.sin(angle_step / 2),
                               angle_step])
        new_truth = compose(truth, true_delta)
        rot1 = np.arctan2(true_delta[1], true_delta[0])
        trans = np.hypot(true_delta[0], true_delta[1])
        rot2 = true_delta[2] - rot1
        rot1 += rng.normal(0.0, odometry_noise[0])
        trans *= 1.0 + rng.normal(0.0, odometry_noise[1])
        rot2 += rng.normal(0.0, odometry_noise[2])
        odometry = compose(odometry, np.array([trans * np.cos(rot1), trans * np.sin(rot1),
                                               rot1 + rot2]))
        truth = new_truth
        world.steps.append(_observe(rng, truth, odometry, landmarks, max_range, sigma_range,
                                    sigma_bearing, detection_probability, clutter_per_step))
    return world


def _separated_points(rng, count: int, extent: float, min_separation: float) -> np.ndarray:
    """Uniform points in the square, redrawn until no two are closer than min_separation."""
    points = rng.uniform(-extent / 2, extent / 2, size=(count, 2))
    for _ in range(100):
        distance = np.hypot(*(points[:, None, :] - points[None, :, :]).transpose(2, 0, 1))
        np.fill_diagonal(distance, np.inf)
        crowded = np.flatnonzero(np.triu(distance < min_separation).any(axis=1))
        if len(crowded) == 0:
            break
        points[crowded] = rng.uniform(-extent / 2, extent / 2, size=(len(crowded), 2))
    return points


def _observe(rng, truth, odometry, landmarks, max_range, sigma_range, sigma_bearing,
             detection_probability, clutter_per_step) -> Step:
    local = relative_pose(np.broadcast_to(truth, (len(landmarks), 3)),
                          np.column_stack([landmarks, np.zeros(len(landmarks))]))
    ranges = np.hypot(local[:, 0], local[:, 1])
    visible = (ranges < max_range) & (rng.random(len(landmarks)) < detection_probability)
    ids = np.flatnonzero(visible)
    obs_r = ranges[ids] + rng.normal(0.0, sigma_range, len(ids))
    obs_b = wrap_angle(np.arctan2(local[ids, 1], local[ids, 0])
                       + rng.normal(0.0, sigma_bearing, len(ids)))
    clutter = rng.poisson(clutter_per_step)
    if clutter:
        obs_r = np.concatenate([obs_r, rng.uniform(1.0, max_range, clutter)])
        obs_b = np.concatenate([obs_b, rng.uniform(-np.pi, np.pi, clutter)])
        ids = np.concatenate([ids, np.full(clutter, -1)])
    keep = obs_r > 0
    return Step(odometry.copy(), truth.copy(), obs_r[keep], obs_b[keep], ids[keep].astype(np.int64))
