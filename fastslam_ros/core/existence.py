# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Existence of tracked features by log-odds (the feature-elimination rule), ROS-free.

A feature (a landmark, a person) carries the log-odds that it exists. Each reading adds tau+
when the feature is observed (saturating at ``LOGODDS_MAX``, so a long-seen feature can still
die in bounded time) and tau- (<= 0) when it lies in the perceptual range, is not occluded and
is not observed; a feature whose log-odds fall below the removal bound is removed. tau+ and
tau- can be given, or follow by Bayes' rule from the sensor's detection probability and
clutter rate (``detection_evidence``). These are small pure functions, shared by both
filters.
"""
from __future__ import annotations

import math

import numpy as np

LOGODDS_MAX = 3.0
"""Saturation of the existence log-odds (probability 0.95): a feature seen for minutes is
removed after as many missed readings as one seen a few times."""


def update_logodds(logodds: np.ndarray, observed: np.ndarray, missed: np.ndarray,
                   logodds_observed: float, logodds_missed: float,
                   logodds_max: float = LOGODDS_MAX) -> np.ndarray:
    """New log-odds: + tau+ where ``observed`` (capped at ``logodds_max``), + tau- where
    ``missed`` (in view, not occluded, not observed); unchanged elsewhere."""
    raised = np.minimum(logodds + logodds_observed, logodds_max)
    return np.where(observed, raised, np.where(missed, logodds + logodds_missed, logodds))


def detection_evidence(detection_probability: float, clutter_rate: float,
                       gate_fraction: float, logodds_max: float) -> tuple[float, float]:
    """(tau+, tau-) of a sensor that detects a feature inside its perceptual range with
    probability P_D and adds ``clutter_rate`` false detections per reading, uniform over that
    range; ``gate_fraction`` is the share of the range a feature's association gate covers.

    A clutter point falls into the gate in one reading with p_F = 1 - exp(-clutter_rate *
    gate_fraction) (Poisson), whether the feature exists or not. Bayes' rule on "the gate
    holds a detection": tau+ = log((P_D + p_F - P_D p_F) / p_F), capped at ``logodds_max``
    (no clutter: a detection is certain evidence); on "the gate holds none":
    tau- = log((1 - P_D) (1 - p_F) / (1 - p_F)) = log(1 - P_D).
    """
    false_alarm = -math.expm1(-clutter_rate * gate_fraction)
    observed = logodds_max
    if false_alarm > 0.0:
        hit = detection_probability + false_alarm - detection_probability * false_alarm
        observed = min(math.log(hit / false_alarm), logodds_max)
    return observed, math.log1p(-detection_probability)


def removed(logodds: np.ndarray, logodds_remove: float) -> np.ndarray:
    """Mask of the features whose log-odds fell below the removal bound."""
    return logodds < logodds_remove


def existence_probability(logodds: np.ndarray) -> np.ndarray:
    """p = 1 / (1 + exp(-l))."""
    return 1.0 / (1.0 + np.exp(-np.asarray(logodds, dtype=float)))


def in_perceptual_range(ranges: np.ndarray, bearings: np.ndarray, min_range: float,
                        max_range: float, field_of_view: float = 2.0 * np.pi) -> np.ndarray:
    """Mask of the points (range m, bearing rad in the sensor frame) the sensor could see:
    ``min_range <= range <= max_range`` and ``|bearing| <= field_of_view / 2``."""
    inside = (ranges >= min_range) & (ranges <= max_range)
    if field_of_view < 2.0 * np.pi:
        inside &= np.abs(bearings) <= 0.5 * field_of_view
    return inside
