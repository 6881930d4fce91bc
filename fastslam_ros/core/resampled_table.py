# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The landmark store's table of block rows per (particle, column), resampled by index arrays:
a resampling records which particle each new one descends from and the rows are gathered
lazily, column by column, when they are read (``LandmarkStore``'s copy on write)."""
from __future__ import annotations

import numpy as np


class ResampledTable:
    """An (M, C) integer table, one row per particle, whose rows follow resampling lazily and
    per column: ``resample`` records the index array; ``refresh`` brings some columns up to
    date (reindexing their rows by the resamplings they have not seen), ``refresh_all`` all.
    Reading a few columns then costs O(M) per column, whatever the table's width."""

    MAX_PENDING = 64
    """Resamplings kept pending at most; then every column is brought up to date."""

    def __init__(self, num_particles: int, width: int) -> None:
        self.data = np.full((num_particles, width), -1, dtype=np.int32)
        """The entries; a column is current once ``refresh`` has seen it."""
        self.epoch = np.zeros(width, dtype=np.int64)
        """Pending resamplings (of ``_steps``) already applied to each column."""
        self._steps: list[np.ndarray] = []
        self._lineage: np.ndarray | None = None

    @property
    def width(self) -> int:
        return self.data.shape[1]

    def resample(self, indices: np.ndarray) -> None:
        """Row m becomes row ``indices[m]`` (for every column, when next read)."""
        self._steps.append(np.asarray(indices, dtype=np.int64))
        self._lineage = None
        if len(self._steps) > self.MAX_PENDING:
            self.refresh_all()

    def lineage(self) -> np.ndarray:
        """(S + 1, M) int64, S pending resamplings: row e holds, for every particle now, the
        row it descends from in a column that has seen the first e of them."""
        if self._lineage is None:
            count = len(self._steps)
            lineage = np.empty((count + 1, self.data.shape[0]), np.int64)
            lineage[count] = np.arange(self.data.shape[0])
            for e in range(count - 1, -1, -1):
                lineage[e] = self._steps[e][lineage[e + 1]]
            self._lineage = lineage
        return self._lineage

    def refresh(self, columns: np.ndarray) -> None:
        """Bring the ``columns`` (any shape, -1 ignored) up to date."""
        if not self._steps:
            return
        columns = np.asarray(columns).reshape(-1)
        stale = np.unique(columns[columns >= 0])
        stale = stale[self.epoch[stale] < len(self._steps)]
        if len(stale) == 0:
            return
        ancestors = self.lineage()[self.epoch[stale]].T                  # (M, len(stale))
        self.data[:, stale] = self.data[ancestors, stale]
        self.epoch[stale] = len(self._steps)

    def refresh_all(self) -> None:
        """Bring every column up to date and forget the pending resamplings."""
        if not self._steps:
            return
        if not self.epoch.any():
            self.data = self.data[self.lineage()[0]]
        else:
            ancestors = self.lineage()[self.epoch]                         # (C, M)
            # C order, as every other table: the compiled kernels are compiled for one layout.
            self.data = np.ascontiguousarray(np.take_along_axis(self.data, ancestors.T, axis=0))
        self.epoch[:] = 0
        self._steps = []
        self._lineage = None

    def row(self, particle: int, width: int) -> np.ndarray:
        """Particle ``particle``'s current entries of the first ``width`` columns (a copy)."""
        if not self._steps:
            return self.data[particle, :width].copy()
        if self._lineage is not None:
            chain = self._lineage[:, particle]
        else:
            # One particle's ancestry: O(S), not the O(S M) of the whole lineage.
            chain = [int(particle)]
            for step in reversed(self._steps):
                chain.append(int(step[chain[-1]]))
            chain = np.array(chain[::-1])
        return self.data[chain[self.epoch[:width]], np.arange(width)]

    def widen(self, extra: int) -> None:
        """Append ``extra`` columns of -1 (current: nothing to reindex)."""
        self.data = np.concatenate(
            [self.data, np.full((self.data.shape[0], extra), -1, self.data.dtype)], axis=1)
        self.epoch = np.concatenate([self.epoch, np.full(extra, len(self._steps), np.int64)])
