# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Range-bearing observation of a point landmark from a sensor mounted on the robot.

The sensor sits at (sensor_x, sensor_y, sensor_yaw) in the robot frame. All functions broadcast
over leading dimensions, so (M, K) particle-landmark pairs are evaluated in one call.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import wrap_angle

MIN_OBSERVATION_RANGE = 1e-3
"""Shortest usable range (m): the inverse model divides by the squared range, so a point at
the sensor origin (or a denormal from byte-swapped data) would give an infinite covariance.
No landmark sensor measures a landmark a millimetre away."""


@dataclass(frozen=True)
class SensorOffset:
    """Sensor pose in the robot frame (m, m, rad); arrays give one pose per observation
    (``map_refinement``)."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0


@dataclass
class ObservationTerms:
    """Intermediate quantities of h(s, m) reused by the Jacobians.

    The bearing is computed on demand: the filter mostly needs the innovation
    ``bearing_innovation``, whose single wrap also covers the predicted bearing's.
    """

    dx: np.ndarray
    dy: np.ndarray
    q: np.ndarray
    lever_x: np.ndarray | float
    """Sensor position relative to the robot, in the world frame (0.0 without an offset)."""
    lever_y: np.ndarray | float
    range: np.ndarray
    heading: np.ndarray
    """Sensor heading in the world, theta + sensor yaw."""

    @property
    def bearing(self) -> np.ndarray:
        return wrap_angle(np.arctan2(self.dy, self.dx) - self.heading)

    def bearing_innovation(self, z_bearing) -> np.ndarray:
        """z_bearing minus the predicted bearing, wrapped."""
        return wrap_angle(z_bearing + self.heading - np.arctan2(self.dy, self.dx))


def observation_terms(px, py, ptheta, mx, my, offset: SensorOffset) -> ObservationTerms:
    """Predicted range with the terms the Jacobians and the bearing need (broadcasting)."""
    if isinstance(offset.x, float) and offset.x == 0.0 and offset.y == 0.0:
        lever_x = lever_y = 0.0
    else:
        c, s = np.cos(ptheta), np.sin(ptheta)
        lever_x = c * offset.x - s * offset.y
        lever_y = s * offset.x + c * offset.y
    dx = mx - (px + lever_x)
    dy = my - (py + lever_y)
    q = dx * dx + dy * dy
    return ObservationTerms(dx, dy, q, lever_x, lever_y, np.sqrt(q), ptheta + offset.yaw)


def heading_column(t: ObservationTerms):
    """(d range / d theta, d bearing / d theta), the heading column of G_s: (0, -1) as plain
    floats when the sensor sits at the robot's origin, which spares the hot paths array work."""
    if isinstance(t.lever_x, float) and t.lever_x == 0.0 and t.lever_y == 0.0:
        return 0.0, -1.0
    return ((t.dx * t.lever_y - t.dy * t.lever_x) / t.range,
            -(t.dx * t.lever_x + t.dy * t.lever_y) / t.q - 1.0)


def inverse_observe(pose, ranges, bearings, offset: SensorOffset = SensorOffset()) -> np.ndarray:
    """g^-1(z, s): landmark position (..., 2) from a range-bearing observation and a pose."""
    pose = np.asarray(pose, float)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    sensor_x = pose[..., 0] + c * offset.x - s * offset.y
    sensor_y = pose[..., 1] + s * offset.x + c * offset.y
    angle = pose[..., 2] + offset.yaw + bearings
    return np.stack([sensor_x + ranges * np.cos(angle), sensor_y + ranges * np.sin(angle)], -1)
