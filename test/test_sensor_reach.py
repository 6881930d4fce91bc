# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The one-time check that the observations fit the configured max_range / field_of_view."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fastslam_ros.node_support.sensor_reach import MIN_POINTS, ReachCheck


def observations(rng: np.random.Generator, count: int, max_range: float,
                 half_opening: float) -> tuple[np.ndarray, np.ndarray]:
    """Points spread evenly over a sensor's disc sector of that range and opening."""
    ranges = max_range * np.sqrt(rng.uniform(0.0, 1.0, count))
    return ranges, rng.uniform(-half_opening, half_opening, count)


def verdict(check: ReachCheck, ranges: np.ndarray, bearings: np.ndarray,
            per_reading: int = 7) -> list[str]:
    """Feed the points reading by reading; the verdict must come exactly once."""
    results = [check.add(ranges[i:i + per_reading], bearings[i:i + per_reading])
               for i in range(0, ranges.size, per_reading)]
    given = [r for r in results if r is not None]
    assert len(given) == 1
    return given[0]


@pytest.mark.parametrize("max_range,field_of_view", [(15.0, math.pi), (8.0, 2 * math.pi)])
def test_a_sensor_described_right_raises_nothing(max_range, field_of_view):
    rng = np.random.default_rng(1)
    ranges, bearings = observations(rng, 2 * MIN_POINTS, max_range, 0.5 * field_of_view)
    assert verdict(ReachCheck(max_range, field_of_view), ranges, bearings) == []


def test_a_range_far_beyond_the_sensors_names_max_range():
    rng = np.random.default_rng(2)
    ranges, bearings = observations(rng, 2 * MIN_POINTS, 10.0, math.pi)
    problems = verdict(ReachCheck(30.0, 2 * math.pi), ranges, bearings)
    assert len(problems) == 1 and "max_range is 30 m" in problems[0]


def test_a_full_circle_for_a_front_sensor_names_field_of_view():
    rng = np.random.default_rng(3)
    ranges, bearings = observations(rng, 2 * MIN_POINTS, 15.0, 0.5 * math.pi)
    problems = verdict(ReachCheck(15.0, 2 * math.pi), ranges, bearings)
    assert len(problems) == 1 and "field_of_view is 6.28 rad" in problems[0]


def test_points_outside_a_too_narrow_opening_name_field_of_view():
    rng = np.random.default_rng(4)
    ranges, bearings = observations(rng, 2 * MIN_POINTS, 15.0, 1.5)
    problems = verdict(ReachCheck(15.0, 2.0), ranges, bearings)
    assert len(problems) == 1 and "outside field_of_view 2.00 rad" in problems[0]
    share = float(problems[0].split(" %")[0])
    assert share == pytest.approx(100 * (1.5 - 1.0) / 1.5, abs=4.0)


def test_points_beyond_max_range_are_left_to_the_drop_counter():
    """A max_range below the sensor's range is a valid choice (far, noisy detections left out)."""
    rng = np.random.default_rng(5)
    ranges, bearings = observations(rng, 2 * MIN_POINTS, 40.0, math.pi)
    assert verdict(ReachCheck(30.0, 2 * math.pi), ranges, bearings) == []


def test_non_finite_points_do_not_count_and_the_verdict_waits_for_enough():
    check = ReachCheck(30.0, 2 * math.pi)
    nan = np.full(10 * MIN_POINTS, np.nan)
    assert check.add(nan, nan) is None and check.problems is None
    ranges, bearings = observations(np.random.default_rng(6), MIN_POINTS - 1, 5.0, math.pi)
    assert check.add(ranges, bearings) is None
    assert check.add(np.array([5.0]), np.array([0.0])) is not None
    assert check.add(ranges, bearings) is None  # once only
