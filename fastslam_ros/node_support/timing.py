# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Time alignment of odometry with sensor readings, shared by the nodes (ROS-free).

A reading is used at the robot pose of its own stamp: ``OdometryHistory`` holds the odometry
newer than the filter's time and hands out the (from, to) pose pairs that carry a filter to a
stamp, interpolating the last one. ``StampGate`` and ``OdometryGate`` tell an input's stray
stamps and odometry glitches from real time jumps and odometry restarts, ``InputRate`` finds
lost messages and silent inputs, ``Throttle`` bounds the rate of an output in node time.
"""
from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from decimal import Decimal

import numpy as np

from fastslam_ros.core.geometry import compose, relative_pose, wrap_angle, wrap_scalar


def seconds_to_nanoseconds(seconds: float) -> int:
    """Float seconds -> integer nanoseconds of the decimal the float stands for.

    A float near a Unix date resolves only 0.24 us: 1700000000.2 is stored as ...2000000477,
    so its binary fraction would be 200000048 ns and ``round(seconds * 1e9)`` is coarser still
    (steps of 256 ns). The shortest decimal that reads back as the float (``repr``) is the time
    meant, so a stamp converted to float and back keeps its nanoseconds wherever the float can
    hold them, and two conversions of one stamp always agree.
    """
    text = repr(float(seconds))
    whole, point, digits = text.partition(".")
    if point and whole.isdigit() and digits.isdigit():  # d.ddd (>= 0, no exponent): no Decimal
        nanoseconds = int(whole) * 1_000_000_000 + int(digits[:9].ljust(9, "0"))
        rest = digits[9:].rstrip("0")  # beyond the nanoseconds: rounded half to even, as below
        if rest and (rest > "5" or rest == "5" and nanoseconds % 2):
            nanoseconds += 1
        return nanoseconds
    whole = math.floor(seconds)
    fraction = Decimal(text) - whole
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

    @property
    def latest_pose(self) -> np.ndarray | None:
        """Pose of the newest odometry, None before the first one."""
        return self._poses[-1] if self._poses else self.anchor_pose

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

    def pose_at(self, stamp: float) -> np.ndarray | None:
        """The odometry pose at ``stamp`` (interpolated), None when it is not held (before the
        anchor or after the newest odometry)."""
        if self.anchor_stamp is None or stamp < self.anchor_stamp:
            return None
        before_stamp, before_pose = self.anchor_stamp, self.anchor_pose
        for after_stamp, after_pose in zip(self._stamps, self._poses):
            if after_stamp >= stamp:
                return interpolate_pose(before_stamp, before_pose, after_stamp, after_pose, stamp)
            before_stamp, before_pose = after_stamp, after_pose
        return before_pose if stamp == before_stamp else None

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


def interpolate_poses(stamps: np.ndarray, poses: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Poses (N, 3) of a timed series at the stamps ``at`` (N,): linear in x, y and in the
    unwrapped heading (the shortest way round between samples less than pi apart); clamped
    at the ends."""
    heading = np.unwrap(poses[:, 2])
    return np.column_stack((np.interp(at, stamps, poses[:, 0]), np.interp(at, stamps, poses[:, 1]),
                            wrap_angle(np.interp(at, stamps, heading))))


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


GAP_FACTOR = 2.5
"""A step between two stamps longer than this many recent intervals is a gap: messages were
lost. A single lost message doubles the step and is not counted: senders stamped by a loaded
computer's clock jitter by as much (two or more lost in a row are)."""
SILENCE_FACTOR = 5.0
"""An input silent for this many recent intervals (and at least ``MIN_SILENCE`` s) has stopped."""
MIN_SILENCE = 1.0


class InputRate:
    """The usual interval between the stamps of one input, and the gaps in it.

    The interval is the mean of the last ``window`` steps between consecutive stamps, gaps left
    out. A step beyond ``GAP_FACTOR`` intervals is a gap and counts ``round(step / interval) -
    1`` missing messages; steps shorter than half an interval right after it (a sender catching
    up: nothing was lost) pay them back.
    """

    def __init__(self, window: int = 64) -> None:
        self._steps: deque[float] = deque(maxlen=window)
        self.interval: float | None = None
        self.missing = 0
        """Messages estimated lost, from the gaps in the stamps."""
        self.largest_gap = 0.0
        """Longest gap (s of stamps) seen."""
        self._owed = 0
        self._last_stamp: float | None = None
        self._last_arrival: float | None = None

    def record(self, stamp: float, arrival: float) -> int:
        """Note one message; returns the change of ``missing`` it made."""
        change = 0
        if self._last_stamp is not None and stamp > self._last_stamp:
            step = stamp - self._last_stamp
            if self.interval is not None and step > GAP_FACTOR * self.interval:
                change = max(round(step / self.interval) - 1, 1)
                self._owed = change
                self.largest_gap = max(self.largest_gap, step)
            elif self.interval is not None and step < 0.5 * self.interval and self._owed:
                change, self._owed = -1, self._owed - 1
            else:
                self._owed = 0
            if change <= 0:
                self._steps.append(step)
                self.interval = sum(self._steps) / len(self._steps)
        if self._last_stamp is None or stamp > self._last_stamp:
            self._last_stamp = stamp
        self._last_arrival = arrival
        self.missing += change
        return change

    def silence(self, now: float) -> float:
        """Seconds (node time) since the last message arrived when that is longer than the input
        usually stays silent; 0 otherwise (or before the rate is known)."""
        if self.interval is None or self._last_arrival is None:
            return 0.0
        silent = now - self._last_arrival
        return silent if silent > max(SILENCE_FACTOR * self.interval, MIN_SILENCE) else 0.0


class Confirmation:
    """A jump in an input is believed after ``needed`` messages in a row agree on it.

    Each message off the input's course is added with ``confirms``; it continues the streak when
    it agrees with the message before it, else it starts a new one. A message on course ends the
    streak (``clear``): one stray message is never taken, and strays that disagree never add up.
    """

    def __init__(self, needed: int) -> None:
        self.needed = needed
        self._streak: list = []

    def confirms(self, message, agrees: Callable[[object], bool]) -> bool:
        """Add an off-course ``message``; ``agrees(previous)`` tells whether it continues the
        previous one. True when it makes ``needed`` in a row (the streak then starts over)."""
        if self._streak and not agrees(self._streak[-1]):
            self._streak.clear()
        self._streak.append(message)
        if len(self._streak) < self.needed:
            return False
        self._streak.clear()
        return True

    def clear(self) -> None:
        """End the streak (a message on course, or a reset)."""
        self._streak.clear()


TIME_JUMP_BACK = 1.0
"""An input stamp this much (s) older than the newest one means time went backwards (a looped
bag, a restarted simulation): the filter resets, once confirmed. Smaller steps back are
out-of-order messages."""
TIME_JUMP_FORWARD = 10.0
"""An input stamp this much (s) newer than the newest one is a jump forward (or a stray stamp)."""
STAMP_CONFIRMATIONS = 3
"""A time jump is accepted only when this many consecutive messages agree on the new time; the
messages before that are dropped as outlier stamps, so one stray stamp is never used and never
resets the filter."""


class StampGate:
    """The newest stamp of a node's inputs, and whether a new stamp fits it.

    A stamp more than TIME_JUMP_BACK s before or TIME_JUMP_FORWARD s after the newest one is an
    outlier until STAMP_CONFIRMATIONS consecutive messages agree on the new time: then time went
    backwards (a looped bag) or jumped forward (a pause), and the run goes on from there.
    """

    USABLE, OUTLIER, BACKWARDS, FORWARD = "usable", "outlier", "backwards", "forward"

    def __init__(self) -> None:
        self.newest: float | None = None
        self._jump = Confirmation(STAMP_CONFIRMATIONS)

    @staticmethod
    def _near(reference: float, stamp: float) -> bool:
        return reference - TIME_JUMP_BACK <= stamp <= reference + TIME_JUMP_FORWARD

    def check(self, stamp: float) -> str:
        """USABLE (the newest stamp moves on), OUTLIER (drop it), or a confirmed jump
        (BACKWARDS, FORWARD), after which ``stamp`` is the newest."""
        newest = self.newest
        if newest is None or self._near(newest, stamp):
            self._jump.clear()
            self.newest = stamp if newest is None else max(newest, stamp)
            return self.USABLE
        if not self._jump.confirms(stamp, lambda previous: self._near(previous, stamp)):
            return self.OUTLIER
        self.newest = stamp
        return self.BACKWARDS if stamp < newest else self.FORWARD

    def clear(self) -> None:
        """Forget the input's time (after a reset the next stamp is taken as it comes)."""
        self.newest = None
        self._jump.clear()


ODOMETRY_CONFIRMATIONS = 5
"""An odometry jump beyond max_speed / max_yaw_rate is accepted (the odometry restarted
elsewhere; the filter carries on from where it was) only when this many consecutive messages
continue it plausibly; before that each one is dropped as implausible."""
ODOMETRY_SLACK = (0.1, 0.1)
"""m and rad allowed on top of max_speed and max_yaw_rate times the step (stamp jitter)."""
MAX_ODOMETRY_COORDINATE = 1e7
"""m: an odometry position farther out is dropped (overflows the motion model's squares)."""


class OdometryGate:
    """The max_speed / max_yaw_rate gate between consecutive odometry poses.

    A jump is implausible (dropped) unless ODOMETRY_CONFIRMATIONS consecutive messages continue
    it plausibly: the odometry then restarted elsewhere, and ``correction`` (the pose of the raw
    odometry frame in the frame the filter follows) shifts so that the jump is no motion.
    """

    PLAUSIBLE, IMPLAUSIBLE, BRIDGED = "plausible", "implausible", "bridged"

    def __init__(self) -> None:
        self.correction = np.zeros(3)
        self._bridged = False
        self._jump = Confirmation(ODOMETRY_CONFIRMATIONS)

    def corrected(self, pose: np.ndarray) -> np.ndarray:
        """A raw odometry pose in the frame the filter follows (the pose itself, heading
        wrapped, until the first jump: no composition on every message)."""
        if self._bridged:
            return compose(self.correction, pose)
        return np.array([pose[0], pose[1], wrap_scalar(float(pose[2]))])

    @staticmethod
    def step_plausible(stamp0: float, pose0: np.ndarray, stamp1: float, pose1: np.ndarray,
                       max_speed: float, max_yaw_rate: float) -> bool:
        """Whether the robot can move from pose0 to pose1 in the time between the stamps."""
        step = stamp1 - stamp0
        return bool(math.hypot(pose1[0] - pose0[0], pose1[1] - pose0[1])
                    <= max_speed * step + ODOMETRY_SLACK[0]
                    and abs(wrap_scalar(pose1[2] - pose0[2]))
                    <= max_yaw_rate * step + ODOMETRY_SLACK[1])

    def check(self, latest_stamp: float, latest_pose: np.ndarray, stamp: float,
              pose: np.ndarray, max_speed: float, max_yaw_rate: float) -> str:
        """PLAUSIBLE, IMPLAUSIBLE (drop it) or BRIDGED: a confirmed jump, after which
        ``correction`` has moved and ``pose`` (corrected, changed in place) is ``latest_pose``."""
        limits = (max_speed, max_yaw_rate)
        if self.step_plausible(latest_stamp, latest_pose, stamp, pose, *limits):
            self._jump.clear()
            return self.PLAUSIBLE
        if not self._jump.confirms((stamp, pose), lambda previous: self.step_plausible(
                *previous, stamp, pose, *limits)):
            return self.IMPLAUSIBLE
        # New frame: the jump itself becomes no motion (latest = shift * pose).
        shift = compose(latest_pose, relative_pose(pose, np.zeros(3)))
        self.correction = compose(shift, self.correction)
        self._bridged = True
        pose[:] = latest_pose
        return self.BRIDGED

    def clear(self) -> None:
        """Back to the raw odometry frame (after a reset)."""
        self.correction = np.zeros(3)
        self._bridged = False
        self._jump.clear()
