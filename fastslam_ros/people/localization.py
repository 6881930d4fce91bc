# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Robot pose particles on the known map: the laser likelihood field and global sampling.

A beam ending at a point d metres from the nearest mapped obstacle has the likelihood
z_hit N(d; 0, sigma_hit^2) + (1 - z_hit) / max_range (Probabilistic Robotics, table 6.3);
beams with no return carry no weight. A beam ending on a person far from every obstacle gets
the uniform part for every particle alike, so people do not bias the robot's pose.
"""
from __future__ import annotations

import math

import numpy as np

from fastslam_ros.core.geometry import circular_mean, compose, wrap_angle
from fastslam_ros.people.grid import OccupancyMap


def sensor_poses(poses: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Map-frame sensor poses (M, 3) of robot poses (M, 3) with the sensor at ``offset``."""
    return compose(poses, np.broadcast_to(offset, poses.shape))


def beam_endpoints(sensors: np.ndarray, ranges: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Map-frame end points (M, B, 2) of beams (B,) from sensor poses (M, 3)."""
    heading = sensors[:, 2:3] + angles[None, :]
    return np.stack([sensors[:, 0:1] + ranges * np.cos(heading),
                     sensors[:, 1:2] + ranges * np.sin(heading)], axis=-1)


def likelihood_field_log_weights(distances: np.ndarray, sigma_hit: float, z_hit: float,
                                 max_range: float) -> np.ndarray:
    """Sum over beams of log(z_hit N(d; 0, sigma_hit^2) + (1 - z_hit) / max_range), per
    particle, for distances (M, B) of beam ends to the nearest obstacle."""
    hit = z_hit / (math.sqrt(2.0 * math.pi) * sigma_hit) * np.exp(
        -0.5 * (distances / sigma_hit) ** 2)
    return np.log(hit + (1.0 - z_hit) / max_range).sum(axis=1)


def sample_free_poses(grid: OccupancyMap, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` poses uniform over the free cells (anywhere inside each), uniform heading."""
    centres = grid.free_cell_centres()
    if len(centres) == 0:
        raise ValueError("the map has no free cell to localize in")
    chosen = centres[rng.integers(len(centres), size=count)]
    jitter = (rng.random((count, 2)) - 0.5) * grid.resolution
    heading = rng.uniform(-math.pi, math.pi, count)
    return np.column_stack([chosen + jitter, heading])


def roughen(poses: np.ndarray, factor: float, rng: np.random.Generator) -> np.ndarray:
    """Roughening (Gordon, Salmond and Smith 1993): poses (M, 3) each moved by
    N(0, (factor E_d M^(-1/3))^2) in x, y and heading, E_d the poses' extent in dimension d
    (heading: about the circular mean), so that copies of one resampled pose spread over the
    gap between the samples and the next readings can pick the best of them."""
    count = len(poses)
    if count < 2:
        return poses.copy()
    offsets = wrap_angle(poses[:, 2] - circular_mean(poses[:, 2]))
    extent = np.array([np.ptp(poses[:, 0]), np.ptp(poses[:, 1]), np.ptp(offsets)])
    moved = poses + rng.standard_normal(poses.shape) * (factor * extent * count ** (-1.0 / 3.0))
    moved[:, 2] = wrap_angle(moved[:, 2])
    return moved


def sample_gaussian_poses(mean: np.ndarray, covariance: np.ndarray, count: int,
                          rng: np.random.Generator) -> np.ndarray:
    """``count`` poses from N(mean, covariance) over (x, y, theta), theta wrapped."""
    covariance = 0.5 * (covariance + covariance.T)
    samples = rng.multivariate_normal(np.asarray(mean, dtype=float), covariance, size=count,
                                      method="eigh")
    samples[:, 2] = wrap_angle(samples[:, 2])
    return samples
