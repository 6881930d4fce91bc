# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""What the people tracker reports: what one reading did (``PeopleTracker.update``'s result),
and the people of a robot particle (``PeopleTracker.published_people``)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class UpdateReport:
    """What one reading did (from every robot particle's view, counted over the best one)."""

    detections: int
    """Detections of the best particle."""
    associated: int
    created: int
    unexplained: int
    """Detections the best particle could not explain (no free person slot)."""
    removed: int
    effective_sample_size: float
    resampled: bool
    converged: bool


@dataclass
class PeopleEstimate:
    """People of one robot particle: stable ``keys`` (N,), ``means`` (N, 2), ``covariances``
    (N, 2, 2) of their position particles, existence probabilities (N,)."""

    keys: np.ndarray
    means: np.ndarray
    covariances: np.ndarray
    existence: np.ndarray
