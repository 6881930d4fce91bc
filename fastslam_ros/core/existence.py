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

The landmark map (FastSLAM, both backends) adds two rules, so that the evidence cannot eat
the map when the pose is slightly off:

* A miss is only a landmark that should have been detected and was not: an observation of the
  reading that the association rejected (it founded a landmark or was an outlier) within
  ``EXPLAINED_GATE`` of a landmark's predicted observation explains that landmark, which is
  then not missed (``explains``). A pose slightly off makes the association reject exactly
  the observations of the landmarks it sees; without the rule each such reading lowers them,
  and the map is removed and mapped again from the drifted pose.
* A confirmed landmark (log-odds at least ``confirmation_logodds``) needs far stronger evidence
  to go than a tentative one (``confirmed_evidence``): a detection of it restores the
  saturation (in a static world, a confirmed landmark seen again exists), and a miss lowers it
  by tau- (l_max - l_c) / ``CONFIRMED_MISS_EVIDENCE``, so it falls back to tentative only
  after a run of misses without a detection whose probability, for a landmark that exists and
  is detected with P_D = 1 - exp(tau-), is exp(-CONFIRMED_MISS_EVIDENCE) (2e-9): 22 readings
  in a row at P_D 0.6, 40 with the default tau- -0.5. Tentative landmarks keep the plain
  Bayes rule.
"""
from __future__ import annotations

import math

import numpy as np

EXPLAINED_GATE = 100.0
"""Squared distance, in standard deviations of the sensor noise (range and bearing), from a
landmark's predicted observation within which an observation the association rejected
explains the landmark's non-detection (10 sigma: beyond what a landmark in its place gives
with the pose right, and well beyond where the association starts rejecting, about 5-6 sigma
with the default p0)."""
CONFIRMED_MISS_EVIDENCE = 20.0
"""-log of the probability of the run of misses that takes a confirmed landmark from the
saturation back to tentative (exp(-20) = 2e-9)."""
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


def existence_logodds(probability: float) -> float:
    """l = log(p / (1 - p)), the inverse of ``existence_probability`` (-inf at 0, inf at 1)."""
    if probability <= 0.0:
        return -math.inf
    return math.log(probability / (1.0 - probability)) if probability < 1.0 else math.inf


def confirmation_logodds(map_min_existence: float, logodds_remove: float) -> float:
    """l_c: the log-odds from which a landmark is confirmed, logit(map_min_existence), at least
    the removal bound (map_min_existence 0 confirms every landmark; 1 none)."""
    return max(existence_logodds(map_min_existence), logodds_remove)


def confirmed_evidence(logodds_missed: float, confirmed: float, logodds_max: float) -> float:
    """tau- of a confirmed landmark: tau- (l_max - l_c) / ``CONFIRMED_MISS_EVIDENCE``, so that
    misses totalling -CONFIRMED_MISS_EVIDENCE of plain evidence take it from ``logodds_max``
    to ``confirmed`` (0 when nothing is confirmed)."""
    if not math.isfinite(confirmed):
        return 0.0
    return logodds_missed * max(logodds_max - confirmed, 0.0) / CONFIRMED_MISS_EVIDENCE


def observed_logodds(logodds: np.ndarray, logodds_observed: float, confirmed: float,
                     logodds_max: float) -> np.ndarray:
    """Log-odds after a detection: ``logodds_max`` for a confirmed landmark, else + tau+
    (capped at ``logodds_max``)."""
    return np.where(logodds >= confirmed, logodds_max,
                    np.minimum(logodds + logodds_observed, logodds_max))


def missed_logodds(logodds: np.ndarray, logodds_missed: float, confirmed: float,
                   confirmed_missed: float) -> np.ndarray:
    """Log-odds after a miss: + ``confirmed_missed`` for a confirmed landmark, else + tau-."""
    return logodds + np.where(logodds >= confirmed, confirmed_missed, logodds_missed)


def explains(range_error: np.ndarray, bearing_error: np.ndarray, range_variance,
              bearing_variance: float) -> np.ndarray:
    """Mask of the (observation, landmark) pairs where the observation lies within
    ``EXPLAINED_GATE`` of the landmark's predicted observation (errors in m and rad, wrapped;
    variances of the sensor noise)."""
    return (range_error * range_error / range_variance
            + bearing_error * bearing_error / bearing_variance) <= EXPLAINED_GATE
