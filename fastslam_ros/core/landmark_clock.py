# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""When each landmark was created and last observed, in odometry distance travelled.

The loop closure (``loop_closure``) and the fault recovery (``fault_recovery``) both tell old
landmarks from young ones and ask whether a landmark was observed since another was created.
Times are kept per landmark key, which a landmark's copies in every particle share: a landmark
is observed when a reading changed its covariance in some particle. Distance, not time,
because a robot standing still neither leaves landmarks nor comes back to them.
"""
from __future__ import annotations

import numpy as np

from .landmark_store import COV, LOGODDS, WorkingSet


class LandmarkClock:
    """Per landmark key: ``travelled`` at its creation and at its latest observation."""

    def __init__(self) -> None:
        self.travelled = 0.0
        """Odometry distance (m) received so far (``FastSLAM.predict``)."""
        self.seen = np.zeros(0)
        """Per landmark key: ``travelled`` when some particle last observed it."""
        self.created = np.zeros(0)
        """Per landmark key: ``travelled`` when it was created."""
        self.num_keys = 0
        self.before: np.ndarray | None = None
        """(M, first_new, 4) covariances and log-odds of the reading's working set before it."""
        self.first_new = 0

    def register(self, next_key: int) -> None:
        """Keys below ``next_key`` not registered yet were created (and observed) now."""
        known = self.num_keys
        if next_key <= known:
            return
        if next_key > len(self.seen):
            # Doubling: a reading creates up to one key per particle and new landmark.
            grow = max(next_key, 2 * len(self.seen)) - len(self.seen)
            self.seen = np.concatenate([self.seen, np.zeros(grow)])
            self.created = np.concatenate([self.created, np.zeros(grow)])
        self.seen[known:next_key] = self.created[known:next_key] = self.travelled
        self.num_keys = next_key

    def before_reading(self, ws: WorkingSet, pending: np.ndarray | None) -> None:
        """Remember the covariances and log-odds of the working set's landmarks (``pending``:
        the resampling the reading applies to it first), to tell which the reading observes
        and which it confirms."""
        kept = ws.state[:, :ws.first_new_slot, COV.start:LOGODDS + 1]
        self.before = kept[pending] if pending is not None else kept.copy()
        self.first_new = ws.first_new_slot

    def after_reading(self, ws: WorkingSet, next_key: int) -> None:
        """Mark the landmarks the reading observed and register the ones it created."""
        first = self.first_new
        changed = ws.valid[:, :first] & (ws.cov[:, :first] != self.before[..., :3]).any(axis=2)
        self.seen[ws.key[:, :first][changed]] = self.travelled
        self.register(next_key)
