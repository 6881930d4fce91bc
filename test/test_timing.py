# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The time gates of the nodes' inputs (ROS-free): stray stamps and odometry glitches are
dropped, a jump that enough messages in a row agree on is taken."""
from __future__ import annotations

import math
from decimal import Decimal

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fastslam_ros.node_support.timing import (ODOMETRY_CONFIRMATIONS, STAMP_CONFIRMATIONS,
                                      TIME_JUMP_BACK, TIME_JUMP_FORWARD, Confirmation,
                                      OdometryGate, OdometryHistory, StampGate,
                                      interpolate_pose, seconds_to_nanoseconds)

USABLE, OUTLIER, BACKWARDS, FORWARD = (StampGate.USABLE, StampGate.OUTLIER, StampGate.BACKWARDS,
                                       StampGate.FORWARD)
PLAUSIBLE, IMPLAUSIBLE, BRIDGED = (OdometryGate.PLAUSIBLE, OdometryGate.IMPLAUSIBLE,
                                   OdometryGate.BRIDGED)


def decimal_nanoseconds(seconds: float) -> int:
    """The nanoseconds of the shortest decimal of ``seconds``, rounded half to even."""
    whole = math.floor(seconds)
    fraction = Decimal(repr(float(seconds))) - whole
    return whole * 1_000_000_000 + int((fraction * 1_000_000_000).to_integral_value())


@settings(max_examples=2000, deadline=None)
@given(st.one_of(st.floats(-1e3, 1e17, allow_nan=False),
                 st.builds(lambda sec, nsec, beyond: float(f"{sec}.{nsec:09d}{beyond}"),
                           st.integers(0, 2**31), st.integers(0, 999_999_999),
                           st.sampled_from(["", "5", "4", "6", "50", "51", "49"]))))
def test_seconds_to_nanoseconds_is_the_decimal_rounded_half_to_even(seconds):
    assert seconds_to_nanoseconds(seconds) == decimal_nanoseconds(seconds)


def test_seconds_to_nanoseconds_at_the_halves_and_the_exponents():
    for seconds in (0.0, 1.0, 2.5e-9, 1.5e-9, 0.0000000005, 0.0000000015, 1.0000000025,
                    1.0000000035, 12.5, 1796197074.6807956, 1e-5, 1.5e-7, 1e16, 3e17, -0.5,
                    -1.0000000005):
        assert seconds_to_nanoseconds(seconds) == decimal_nanoseconds(seconds), seconds
    assert seconds_to_nanoseconds(0.0000000015) == 2  # half to even: 1.5 ns -> 2
    assert seconds_to_nanoseconds(0.0000000025) == 2  # 2.5 ns -> 2


def test_the_confirmation_counts_only_agreeing_messages_in_a_row():
    streak = Confirmation(3)

    def near(stamp):
        return lambda previous: abs(stamp - previous) < 1.0

    verdicts = [streak.confirms(stamp, near(stamp)) for stamp in (10.0, 10.5, 50.0, 50.2, 50.4)]
    assert verdicts == [False, False, False, False, True]  # 10.x broken off by 50.0
    assert not streak.confirms(50.6, near(50.6))  # started over after the confirmation
    streak.clear()
    assert [streak.confirms(s, near(s)) for s in (50.8, 51.0, 51.2)] == [False, False, True]


def test_stamp_gate_takes_stamps_near_the_newest_and_keeps_the_newest():
    gate = StampGate()
    assert [gate.check(s) for s in (100.0, 100.1, 99.5, 100.2)] == [USABLE] * 4
    assert gate.newest == 100.2  # a late (out-of-order) stamp does not move it back
    # The window's edges are inside it; a hair beyond is not.
    assert gate.check(100.2 - TIME_JUMP_BACK) == USABLE
    assert gate.check(100.2 + TIME_JUMP_FORWARD) == USABLE and gate.newest == 110.2
    assert gate.check(np.nextafter(110.2 - TIME_JUMP_BACK, 0.0)) == OUTLIER
    assert gate.newest == 110.2


def test_stamp_gate_drops_a_stray_stamp_and_an_agreeing_message_ends_the_streak():
    gate = StampGate()
    gate.check(100.0)
    assert gate.check(500.0) == OUTLIER and gate.newest == 100.0
    assert gate.check(500.1) == OUTLIER
    assert gate.check(100.1) == USABLE  # back on course: the two strays are forgotten
    verdicts = [gate.check(500.2 + 0.1 * k) for k in range(STAMP_CONFIRMATIONS)]
    assert verdicts == [OUTLIER] * (STAMP_CONFIRMATIONS - 1) + [FORWARD]
    assert gate.newest == pytest.approx(500.2 + 0.1 * (STAMP_CONFIRMATIONS - 1))


def test_stamp_gate_confirms_a_jump_back_after_messages_in_a_row_agree():
    gate = StampGate()
    gate.check(100.0)
    verdicts = [gate.check(s) for s in (20.0, 20.1, 20.2)]
    assert verdicts == [OUTLIER, OUTLIER, BACKWARDS] and gate.newest == 20.2
    assert gate.check(20.3) == USABLE


def test_stamp_gate_strays_that_disagree_never_add_up():
    gate = StampGate()
    gate.check(100.0)
    # Each stray is far from the one before it: no two agree, nothing is confirmed.
    assert [gate.check(s) for s in (500.0, 20.0, 900.0, 300.0, 40.0)] == [OUTLIER] * 5
    assert gate.newest == 100.0
    # The last stray starts a streak of its own: two more agreeing messages confirm it.
    assert [gate.check(s) for s in (40.5, 41.0)] == [OUTLIER, BACKWARDS]


def test_stamp_gate_clear_takes_the_next_stamp_as_it_comes():
    gate = StampGate()
    gate.check(100.0)
    gate.check(500.0)
    gate.clear()
    assert gate.newest is None
    assert gate.check(3.0) == USABLE and gate.newest == 3.0
    assert gate.check(500.0) == OUTLIER  # the stray before the clear does not count


LIMITS = (1.0, 0.5)
"""max_speed (m/s), max_yaw_rate (rad/s) of the odometry gate tests."""


def test_odometry_gate_bounds_a_step_by_speed_and_yaw_rate_plus_slack():
    # 0.5 s at 1 m/s and 0.5 rad/s, plus 0.1 m and 0.1 rad of slack: 0.6 m, 0.35 rad.
    start = np.zeros(3)
    assert OdometryGate.step_plausible(0.0, start, 0.5, np.array([0.59, 0.0, 0.34]), *LIMITS)
    assert not OdometryGate.step_plausible(0.0, start, 0.5, np.array([0.37, 0.48, 0.0]),
                                           *LIMITS)  # 0.605 m diagonally
    assert not OdometryGate.step_plausible(0.0, start, 0.5, np.array([0.0, 0.0, 0.36]), *LIMITS)
    # Heading steps are taken the short way round.
    assert OdometryGate.step_plausible(0.0, np.array([0.0, 0.0, 3.1]), 0.5,
                                       np.array([0.0, 0.0, -3.1]), *LIMITS)


def odometry_run(gate: OdometryGate, poses, latest=(0.0, np.zeros(3)), period: float = 0.1):
    """Verdicts of ``gate`` on raw ``poses`` one ``period`` apart, after ``latest``; a pose
    taken becomes the latest, as in the node."""
    verdicts, (stamp, pose_latest) = [], latest
    for k, raw in enumerate(poses):
        now = latest[0] + (k + 1) * period
        pose = gate.corrected(np.array(raw, float))
        verdict = gate.check(stamp, pose_latest, now, pose, *LIMITS)
        verdicts.append(verdict)
        if verdict != IMPLAUSIBLE:
            stamp, pose_latest = now, pose
    return verdicts, pose_latest


def test_odometry_gate_takes_plausible_steps_and_drops_a_glitch():
    gate = OdometryGate()
    verdicts, latest = odometry_run(gate, [(0.05, 0, 0), (40.0, 0, 0), (0.15, 0, 0)])
    assert verdicts == [PLAUSIBLE, IMPLAUSIBLE, PLAUSIBLE]
    np.testing.assert_allclose(latest, [0.15, 0.0, 0.0])
    assert not gate.correction.any()


def test_odometry_gate_bridges_a_confirmed_restart_as_no_motion():
    gate = OdometryGate()
    latest = (0.0, np.array([1.0, 2.0, math.pi / 2]))
    # The odometry restarts at its origin and drives on 0.05 m per step along its own x.
    restart = [(0.05 * k, 0.0, 0.0) for k in range(ODOMETRY_CONFIRMATIONS + 2)]
    verdicts, pose = odometry_run(gate, restart, latest)
    assert verdicts == ([IMPLAUSIBLE] * (ODOMETRY_CONFIRMATIONS - 1) + [BRIDGED]
                        + [PLAUSIBLE] * 2)
    # The confirming message is the latest pose itself; the two after it moved 0.05 m each,
    # along the followed heading (+y).
    np.testing.assert_allclose(pose, [1.0, 2.1, math.pi / 2], atol=1e-12)
    np.testing.assert_allclose(gate.corrected(np.array([1.0, 0.0, 0.0])),
                               [1.0, 2.0 + 1.0 - 0.05 * (ODOMETRY_CONFIRMATIONS - 1),
                                math.pi / 2], atol=1e-12)


def test_odometry_gate_streak_ends_on_an_agreeing_message_and_on_disagreeing_ones():
    gate = OdometryGate()
    far = [(20.0 + 0.01 * k, 0.0, 0.0) for k in range(ODOMETRY_CONFIRMATIONS - 1)]
    verdicts, _ = odometry_run(gate, far + [(0.0, 0.0, 0.0)] + far)
    assert verdicts == [IMPLAUSIBLE] * len(far) + [PLAUSIBLE] + [IMPLAUSIBLE] * len(far)
    # Glitches that do not continue each other (20 m apart) never confirm a jump.
    verdicts, _ = odometry_run(gate, [(20.0 * (-1) ** k, 0.0, 0.0) for k in range(12)])
    assert verdicts == [IMPLAUSIBLE] * 12 and not gate.correction.any()


def test_odometry_gate_clear_returns_to_the_raw_frame():
    gate = OdometryGate()
    odometry_run(gate, [(10.0, 0.0, 0.0)] * ODOMETRY_CONFIRMATIONS)
    assert gate.correction.any()
    gate.clear()
    assert not gate.correction.any()
    np.testing.assert_allclose(gate.corrected(np.array([3.0, 4.0, 2 * math.pi + 0.5])),
                               [3.0, 4.0, 0.5], atol=1e-12)


def test_odometry_history_pose_at_interpolates_what_it_holds_without_moving_the_anchor():
    """Between held poses the pose is interpolated as ``advance`` would; at the anchor and the
    newest pose it is theirs; before the anchor or after the newest odometry it is unknown."""
    history = OdometryHistory()
    poses = [np.array([0.1 * k, 0.0, 0.3 * k]) for k in range(4)]
    for k, pose in enumerate(poses):
        history.append(0.1 * k, pose)
    history.advance(0.05)
    anchor = history.anchor_pose.copy()
    np.testing.assert_allclose(history.pose_at(0.05), anchor)
    np.testing.assert_allclose(history.pose_at(0.25),
                               interpolate_pose(0.2, poses[2], 0.3, poses[3], 0.25))
    np.testing.assert_allclose(history.pose_at(0.3), poses[3])
    assert history.pose_at(0.31) is None and history.pose_at(0.04) is None
    assert history.anchor_stamp == 0.05 and np.array_equal(history.anchor_pose, anchor)
