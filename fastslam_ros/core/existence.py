"""Existence of tracked features by log-odds (the feature-elimination rule), ROS-free.

A feature (a landmark, a person) carries the log-odds that it exists. Each reading adds tau+
when the feature is observed (saturating at ``LOGODDS_MAX``, so a long-seen feature can still
die in bounded time) and tau- (<= 0) when it lies in the perceptual range, is not occluded and
is not observed; a feature whose log-odds fall below the removal bound is removed. These are
small pure functions on arrays of any shape, shared by both filters.
"""
from __future__ import annotations

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
