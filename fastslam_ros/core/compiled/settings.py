# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The settings of the compiled reading as typed records numba reads by field: the filter's
constants (``ReadingSettings``, written once per configuration by ``reading_settings``) and
what changes from one reading to the next (``ReadingPlan``, by ``reading_plan``)."""
from __future__ import annotations

from typing import NamedTuple

MODE_CODES = {"known": 0, "ml": 1, "monte_carlo": 2, "two_gate": 3}
"""``ReadingSettings.association`` of each association rule."""


class ReadingSettings(NamedTuple):
    """The filter's constants as the kernels read them (variances in m^2 and rad^2)."""

    sensor_x: float
    sensor_y: float
    sensor_yaw: float
    range_variance: float
    sigma_range_per_meter: float
    bearing_variance: float
    log_p0: float
    association_gate: float
    new_landmark_gate: float
    outlier_probability: float
    log_outlier: float
    min_range: float
    max_range: float
    field_of_view: float
    logodds_observed: float
    """tau+ (``FastSLAMConfig.existence_evidence``)."""
    logodds_missed: float
    """tau-."""
    logodds_remove: float
    logodds_max: float
    confirmed: float
    """l_c, the log-odds from which a landmark is confirmed (``FastSLAMConfig.confirmation``)."""
    confirmed_missed: float
    """tau- of a confirmed landmark."""
    explained_gate: float
    alpha1: float
    alpha2: float
    alpha3: float
    alpha4: float
    min_translation_sigma: float
    min_rotation_sigma: float
    rotation_variance_per_radian: float
    rotation_variance_per_meter: float
    translation_variance_per_meter: float
    translation_variance_per_radian: float
    association: int
    """The association rule (``MODE_CODES``)."""
    localization: bool
    central: bool
    """``best_particle`` is ``central``."""


class ReadingPlan(NamedTuple):
    """One reading's entries: what it reaches and which of its stages run."""

    reach: float
    """Distance from a particle's pose within which its landmarks are candidates."""
    first_key: int
    """The landmark store's next key."""
    existing: int
    """Working-set columns holding landmarks before the reading (``first_new_slot``)."""
    has_cov: bool
    """The observations are scored with the prior's covariance (FastSLAM 2.0)."""
    propose: bool
    """FastSLAM 2.0's proposal and draw run."""
    score_known: bool
    """With known ids, the pairs are scored (for the weight or the outlier test)."""
    propagate: bool
    """The prior's covariance is propagated in the reading (``DeferredMotion``)."""
    prior_has_cov: bool
    """It is propagated from a covariance (else from zero)."""


def reading_settings(config, offset, log_p0: float, log_outlier: float,
                     logodds_max: float) -> ReadingSettings:
    """``ReadingSettings`` of a validated ``FastSLAMConfig`` (every field of one Python type,
    so that no configuration compiles a kernel anew)."""
    observed, missed = config.existence_evidence()
    confirmed, confirmed_missed = config.confirmation()
    floats = (
        offset.x, offset.y, offset.yaw, config.sigma_range ** 2, config.sigma_range_per_meter,
        config.sigma_bearing ** 2, log_p0, config.association_gate, config.new_landmark_gate,
        config.outlier_probability, log_outlier, config.min_range, config.max_range,
        config.field_of_view, observed, missed, config.logodds_remove, logodds_max, confirmed,
        confirmed_missed, config.explained_gate(), config.alpha1, config.alpha2, config.alpha3,
        config.alpha4, config.min_translation_sigma, config.min_rotation_sigma,
        config.rotation_variance_per_radian, config.rotation_variance_per_meter,
        config.translation_variance_per_meter, config.translation_variance_per_radian)
    return ReadingSettings(*(float(value) for value in floats),
                           association=MODE_CODES[config.association],
                           localization=config.mode == "localization",
                           central=config.best_particle == "central")


def reading_plan(settings: ReadingSettings, reach: float, first_key: int, existing: int,
                 has_cov: bool, propose: bool, motion_from_cov: bool | None) -> ReadingPlan:
    """The ``ReadingPlan`` of a reading; ``motion_from_cov``: None when the prior's covariance
    is not propagated in the reading, else whether it is propagated from a covariance."""
    # FastSLAM 2.0 weighs the associated observations by the proposal's joint likelihood,
    # and without an outlier test nothing needs the likelihood of a known id's landmark.
    score_known = not (has_cov and settings.outlier_probability == 0.0)
    return ReadingPlan(float(reach), int(first_key), int(existing), bool(has_cov),
                       bool(propose), score_known, motion_from_cov is not None,
                       bool(motion_from_cov))
