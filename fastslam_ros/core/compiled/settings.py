# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The settings of one compiled reading, packed once per configuration: floats ``fp`` and
integers ``ip`` at the indices named here (``reading_settings`` is the only writer)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


MODE_CODES = {"known": 0, "ml": 1, "monte_carlo": 2, "two_gate": 3}


# Layout of the settings of a reading: floats ``fp`` and integers ``ip`` (``ReadingSettings``).
F_OX, F_OY, F_OYAW, F_NOISE_R, F_NOISE_R_PER_M, F_NOISE_B = 0, 1, 2, 3, 4, 5


F_LOG_P0, F_GATE, F_NEW_GATE, F_EPS, F_LOG_OUTLIER = 6, 7, 8, 9, 10


F_MIN_RANGE, F_MAX_RANGE, F_FOV = 11, 12, 13


F_LOGODDS_OBSERVED, F_LOGODDS_MISSED, F_LOGODDS_REMOVE, F_LOGODDS_MAX = 14, 15, 16, 17


F_REACH = 18


F_ALPHAS = 19                                  # alpha1..alpha4


F_MIN_TRANSLATION_SIGMA, F_MIN_ROTATION_SIGMA = 23, 24


F_LINEAR_NOISE = 25                            # the four random-walk terms (``motion``)


F_MOTION = 29                                  # rot1, trans, rot2 and their variances


F_CONFIRMED, F_CONFIRMED_MISSED, F_EXPLAINED_GATE = 35, 36, 37   # ``existence``'s rules
NUM_F = 38


I_MODE, I_LOCALIZATION, I_CENTRAL, I_SCORE_KNOWN, I_HAS_COV, I_PROPOSE, I_FIRST_KEY = range(7)


I_MOTION, I_PRIOR_COV = 7, 8                   # the reading propagates the prior's covariance


NUM_I = 9


class ReadingSettings(NamedTuple):
    """The filter's constants in the kernels' layout (``F_*`` floats, ``I_*`` integers)."""

    floats: np.ndarray
    integers: np.ndarray


def reading_settings(config, offset, log_p0: float, log_outlier: float,
                     logodds_max: float) -> ReadingSettings:
    """``ReadingSettings`` of a validated ``FastSLAMConfig`` (the per-reading entries, reach,
    first key and which stages run, are filled by ``update_reading``)."""
    floats = np.zeros(NUM_F)
    floats[[F_OX, F_OY, F_OYAW]] = offset.x, offset.y, offset.yaw
    floats[F_NOISE_R] = config.sigma_range ** 2
    floats[F_NOISE_R_PER_M] = config.sigma_range_per_meter
    floats[F_NOISE_B] = config.sigma_bearing ** 2
    floats[F_LOG_P0], floats[F_GATE] = log_p0, config.association_gate
    floats[F_NEW_GATE] = config.new_landmark_gate
    floats[F_EPS], floats[F_LOG_OUTLIER] = config.outlier_probability, log_outlier
    floats[[F_MIN_RANGE, F_MAX_RANGE, F_FOV]] = (config.min_range, config.max_range,
                                                 config.field_of_view)
    floats[[F_LOGODDS_OBSERVED, F_LOGODDS_MISSED, F_LOGODDS_REMOVE, F_LOGODDS_MAX]] = (
        *config.existence_evidence(), config.logodds_remove, logodds_max)
    floats[[F_CONFIRMED, F_CONFIRMED_MISSED]] = config.confirmation()
    floats[F_EXPLAINED_GATE] = config.explained_gate()
    floats[F_ALPHAS:F_ALPHAS + 4] = (config.alpha1, config.alpha2, config.alpha3, config.alpha4)
    floats[F_MIN_TRANSLATION_SIGMA] = config.min_translation_sigma
    floats[F_MIN_ROTATION_SIGMA] = config.min_rotation_sigma
    floats[F_LINEAR_NOISE:F_LINEAR_NOISE + 4] = (
        config.rotation_variance_per_radian, config.rotation_variance_per_meter,
        config.translation_variance_per_meter, config.translation_variance_per_radian)
    integers = np.zeros(NUM_I, np.int64)
    integers[I_MODE] = MODE_CODES[config.association]
    integers[I_LOCALIZATION] = config.mode == "localization"
    integers[I_CENTRAL] = config.best_particle == "central"
    return ReadingSettings(floats, integers)
