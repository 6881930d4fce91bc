"""Time alignment of odometry with sensor readings, shared by the nodes (ROS-free).

A reading is used at the robot pose of its own stamp: ``OdometryHistory`` holds the odometry
newer than the filter's time and hands out the (from, to) pose pairs that carry a filter to a
stamp, interpolating the last one. ``Throttle`` bounds the rate of an output in node time.
"""
from __future__ import annotations

import math
from collections import deque
from decimal import Decimal

import numpy as np

from fastslam_ros.core.geometry import wrap_angle


def seconds_to_nanoseconds(seconds: float) -> int:
    """Float seconds -> integer nanoseconds of the decimal the float stands for.

    A float near a Unix date resolves only 0.24 us: 1700000000.2 is stored as ...2000000477,
    so its binary fraction would be 200000048 ns and ``round(seconds * 1e9)`` is coarser still
    (steps of 256 ns). The shortest decimal that reads back as the float (``repr``) is the time
    meant, so a stamp converted to float and back keeps its nanoseconds wherever the float can
    hold them, and two conversions of one stamp always agree.
    """
    whole = math.floor(seconds)
    fraction = Decimal(repr(float(seconds))) - whole
    return whole * 1_000_000_000 + int((fraction * 1_000_000_000).to_integral_value())


class OdometryHistory:
    """Odometry after the filter's time, to interpolate poses at observation stamps.

    ``anchor`` is the odometry pose at the filter's time (the end of the last prediction);
    ``advance(t)`` returns the consecutive (from, to) odometry pose pairs that carry the filter
    from there to ``t`` and moves the anchor to ``t``.
    """

    def __init__(self) -> None:
        self.anchor_stamp: float | None = None
        self.anchor_pose: np.ndarray | None = None
        self._stamps: deque[float] = deque()
        self._poses: deque[np.ndarray] = deque()

    @property
    def latest_stamp(self) -> float | None:
        """Stamp of the newest odometry, None before the first one."""
        return self._stamps[-1] if self._stamps else self.anchor_stamp

    def append(self, stamp: float, pose: np.ndarray) -> None:
        """Add a pose newer than every pose held (the first one becomes the anchor)."""
        if self.anchor_stamp is None:
            self.anchor_stamp, self.anchor_pose = stamp, pose
        else:
            self._stamps.append(stamp)
            self._poses.append(pose)

    def covers(self, stamp: float) -> bool:
        """Whether odometry up to ``stamp`` has arrived."""
        return self.latest_stamp is not None and self.latest_stamp >= stamp

    def advance(self, stamp: float) -> list[tuple[np.ndarray, np.ndarray]]:
        """Pose pairs from the anchor to ``stamp`` (to the newest odometry if it ends earlier)."""
        steps = []
        while self._stamps and self._stamps[0] <= stamp:
            steps.append((self.anchor_pose, self._poses[0]))
            self.anchor_stamp, self.anchor_pose = self._stamps.popleft(), self._poses.popleft()
        if self._stamps and stamp > self.anchor_stamp:
            pose = interpolate_pose(self.anchor_stamp, self.anchor_pose,
                                    self._stamps[0], self._poses[0], stamp)
            steps.append((self.anchor_pose, pose))
            self.anchor_stamp, self.anchor_pose = stamp, pose
        return steps


def interpolate_pose(stamp0: float, pose0: np.ndarray, stamp1: float, pose1: np.ndarray,
                     stamp: float) -> np.ndarray:
    """Pose at ``stamp`` between two timed poses: linear in x, y; shortest way round in theta."""
    fraction = (stamp - stamp0) / (stamp1 - stamp0)
    x, y = pose0[:2] + fraction * (pose1[:2] - pose0[:2])
    return np.array([x, y, wrap_angle(pose0[2] + fraction * wrap_angle(pose1[2] - pose0[2]))])


class Throttle:
    """Lets an output through at most once per period of node time (rate 0: never)."""

    def __init__(self, rate: float) -> None:
        self.rate = rate
        self._last: float | None = None

    def due(self, now: float) -> bool:
        """True, and restart the period, when the output may be published at ``now``."""
        if self.rate <= 0.0:
            return False
        if self._last is None or now - self._last >= 1.0 / self.rate or now < self._last:
            self._last = now
            return True
        return False
