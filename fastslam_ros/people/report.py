# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""What one reading of the people tracker did (``PeopleTracker.update``'s result)."""
from __future__ import annotations

from dataclasses import dataclass


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
