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

Motion = tuple[float, tuple[float, float]]
"""(yaw rate (rad/s), velocity (m/s) in the laser's frame) of a laser over its sweep."""
STILL: Motion = (0.0, (0.0, 0.0))
MOTION_WINDOW = 0.5
"""The longest sweep (s) deskewed at the odometry's motion over it (a scan waits that long for
the odometry); without that, a scan is deskewed at the odometry's motion since the previous
scan when that came at most this long before it (after a longer gap that motion need not be
the sweep's)."""
SWEEP_SLACK = 1.25
"""A sweep (``time_increment`` x the beams) lasts at most this many times the time since the
previous scan: a laser sweeps within its scan period (the slack is for jittered stamps), so a
longer one is a ``time_increment`` in the wrong unit."""


def sweep_duration(time_increment: float, beams: int) -> float:
    """How long (s) a laser takes to sweep ``beams`` beams ``time_increment`` s apart."""
    return abs(time_increment) * (beams - 1)


def sweep_problem(time_increment: float, beams: int, elapsed: float, window: float) -> str:
    """Why a scan of ``beams`` beams ``time_increment`` s apart, ``elapsed`` s after the
    previous scan, cannot be deskewed at the motion between the two ('' when it can): too long
    after it (over ``window`` s) for that motion to stand for the sweep's, or a sweep longer
    than the scan period allows (SWEEP_SLACK)."""
    if not 0.0 < elapsed <= window:
        return f"{elapsed:.3g} s since the previous scan (over {window:g} s)"
    sweep = sweep_duration(time_increment, beams)
    if sweep > SWEEP_SLACK * elapsed:
        return (f"time_increment {time_increment:.3g} s x {beams} beams sweeps {sweep:.3g} s, "
                f"longer than the {elapsed:.3g} s since the previous scan")
    return ""


def sweep_motion(previous: np.ndarray, now: np.ndarray, elapsed: float,
                 offset: np.ndarray) -> Motion:
    """(yaw rate (rad/s), the laser's velocity (m/s) in its own frame) of a robot that moved
    from odometry pose ``previous`` to ``now`` in ``elapsed`` s at a constant turn rate and
    velocity in its own frame (the step's SE(2) logarithm: a unicycle's arc, not its chord),
    its laser mounted at ``offset`` (x, y, yaw) on it. The laser moves with the robot, plus
    the turn's velocity about the robot's centre."""
    step = relative_pose(previous, now)                  # in the frame of ``previous``
    turn = float(step[2])
    yaw_rate = turn / elapsed
    # The step's translation is V(turn) v elapsed, V = [[a, -b], [b, a]]: solve for v.
    a = math.sin(turn) / turn if abs(turn) > 1e-9 else 1.0
    b = (1.0 - math.cos(turn)) / turn if abs(turn) > 1e-9 else 0.5 * turn
    scale = 1.0 / ((a * a + b * b) * elapsed)
    vx = (a * step[0] + b * step[1]) * scale - yaw_rate * offset[1]
    vy = (-b * step[0] + a * step[1]) * scale + yaw_rate * offset[0]
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


def at_beam_time(x: np.ndarray, y: np.ndarray, elapsed: np.ndarray, yaw_rate: float,
                 velocity: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The inverse of ``at_first_beam``: points (m) given in the frame the laser had at its
    first beam, in the frame it had ``elapsed`` (s) later (where a beam taken then saw
    them)."""
    turn = yaw_rate * np.asarray(elapsed, float)
    c, s = np.cos(turn), np.sin(turn)
    dx, dy = x - velocity[0] * elapsed, y - velocity[1] * elapsed
    return c * dx + s * dy, -s * dx + c * dy


class SweepMotion:
    """The laser's motion over each scan's sweep: from the odometry poses at the sweep's
    first and last beam when the odometry covers it, else from those at the previous and this
    scan's stamps (``sweep_motion``), when that fits (``sweep_problem``)."""

    def __init__(self) -> None:
        self._previous: tuple[float, np.ndarray] | None = None

    def clear(self) -> None:
        """Forget the previous scan (a reset)."""
        self._previous = None

    def motion(self, stamp: float, pose: np.ndarray | None, time_increment: float, beams: int,
               offset: np.ndarray, end_pose: np.ndarray | None = None) -> tuple[Motion, str]:
        """(the motion of the scan of ``stamp``, whose first beam the laser took at odometry
        pose ``pose`` and whose last at ``end_pose`` (None: unknown), or STILL; why it is
        STILL for a swept scan, '' otherwise)."""
        previous = self._previous
        self._previous = None if pose is None else (stamp, np.array(pose, float))
        if pose is None or time_increment == 0.0:
            return STILL, ""
        sweep = sweep_duration(time_increment, beams)
        if end_pose is not None and 0.0 < sweep <= MOTION_WINDOW and (
                previous is None or sweep <= SWEEP_SLACK * (stamp - previous[0])):
            return sweep_motion(pose, end_pose, sweep, offset), ""
        if previous is None:
            return STILL, ""
        elapsed = stamp - previous[0]
        problem = sweep_problem(time_increment, beams, elapsed, MOTION_WINDOW)
        if problem:
            return STILL, problem
        return sweep_motion(previous[1], pose, elapsed, offset), ""


def sweep_end(stamp: float, time_increment: float, beams: int) -> float:
    """The stamp up to which a scan of ``stamp`` waits for odometry to be deskewed at its own
    motion: its last beam's, or its own for a sweep longer than MOTION_WINDOW (no laser's)."""
    sweep = sweep_duration(time_increment, beams)
    return stamp + sweep if sweep <= MOTION_WINDOW else stamp
