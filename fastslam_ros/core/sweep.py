# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A laser that sweeps: its beams are taken one after the other (``LaserScan.time_increment``
apart) while the robot moves, so a return taken late in the sweep is seen from elsewhere than
the first beam, whose time the scan's stamp gives. Both the people tracker (whole scans) and
the landmark extractor (landmarks) bring what they saw back to the first beam's pose with the
robot's motion from odometry, here, at a constant turn rate and velocity over the sweep."""
from __future__ import annotations

import math

import numpy as np

from fastslam_ros.core.geometry import relative_pose


def sweep_motion(previous: np.ndarray, now: np.ndarray, elapsed: float,
                 offset: np.ndarray) -> tuple[float, tuple[float, float]]:
    """(yaw rate (rad/s), the laser's velocity (m/s) in its own frame) of a robot that moved
    from odometry pose ``previous`` to ``now`` in ``elapsed`` s, its laser mounted at
    ``offset`` (x, y, yaw) on it. The laser moves with the robot, plus the turn's velocity
    about the robot's centre."""
    step = relative_pose(previous, now)                  # in the frame of ``previous``
    yaw_rate = float(step[2]) / elapsed
    c, s = math.cos(step[2]), math.sin(step[2])          # into the robot's frame now
    vx = (c * step[0] + s * step[1]) / elapsed - yaw_rate * offset[1]
    vy = (-s * step[0] + c * step[1]) / elapsed + yaw_rate * offset[0]
    c, s = math.cos(offset[2]), math.sin(offset[2])      # into the laser's frame
    return yaw_rate, (c * vx + s * vy, -s * vx + c * vy)


def at_first_beam(x: np.ndarray, y: np.ndarray, elapsed: np.ndarray, yaw_rate: float,
                  velocity: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Points (m) seen at ``x``, ``y`` in the laser's frame ``elapsed`` (s) after its first
    beam, in the frame the laser had at its first beam, for a laser turning at ``yaw_rate``
    (rad/s) and moving at ``velocity`` (m/s, in that frame): turned by the yaw since, moved by
    the travel since (first order in the sweep's time)."""
    turn = yaw_rate * np.asarray(elapsed, float)
    c, s = np.cos(turn), np.sin(turn)
    return (c * x - s * y + velocity[0] * elapsed,
            s * x + c * y + velocity[1] * elapsed)
