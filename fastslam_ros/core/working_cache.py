# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The cache policy of the working set: which landmarks a reading works on, and when they go
back to the shared store.

``FastSLAM`` reads and updates landmarks only through a dense working set (``WorkingSet``, the
landmarks of every particle in the cells around the robot). Gathering one from the store and
writing it back costs more than a reading's math, so the working set is kept across readings
while it still holds the cells the sensor can reach (and, with known ids, the cells of the
observed ids) and has free columns for new landmarks; the robot pays for gathering and writing
back once per cell change, not once per reading.
"""
from __future__ import annotations

import numpy as np

from .landmark_store import LandmarkStore, WorkingSet

NEW_SLOTS_PER_OBSERVATION = 3
"""Free working-set columns per observation of the reading that gathers it: each observation
that creates a landmark (in any particle) takes one, and a full working set is gathered
again."""


class WorkingSetCache:
    """The working set of the latest reading over a ``LandmarkStore`` (``current``, or None)."""

    def __init__(self, store: LandmarkStore, track_labels: bool) -> None:
        self.store = store
        self.track_labels = track_labels
        """Known ids: the store keeps the column of each label (``LandmarkStore.scatter``)."""
        self._ws: WorkingSet | None = None
        self.pending: np.ndarray | None = None
        """Compiled backend: the resampling (particle m takes the entries of particle
        ``pending[m]``) not yet applied to the working set; the next reading's kernels apply
        it on their way (``compiled.update_reading``), anything else through ``current``."""
        self._box = (0, 0, 0, 0)
        self._labels: set[int] = set()

    @property
    def current(self) -> WorkingSet | None:
        """The working set of the latest reading (resampled), or None."""
        if self.pending is not None:
            self._ws = self.store.kernels.reindex(self._ws, self.pending)
            self.pending = None
        return self._ws

    def for_reading(self, poses: np.ndarray, reach: float, count: int, labels,
                    lazy: bool = False) -> WorkingSet:
        """Every particle's landmarks in the cells within ``reach`` of ``poses``, with free
        columns for the ``count`` observations' new landmarks; ``labels``: the observed ids
        (known association) or None.

        The previous working set is reused while it still holds those cells (and the cells of
        the observed ids) and has free columns; otherwise it is written back and a new one
        gathered. ``lazy``: a reused working set comes without the resampling ``pending``,
        which the caller applies and hands back (``took``).
        """
        store = self.store
        if store.kernels is None:
            low, high = poses[:, :2].min(axis=0) - reach, poses[:, :2].max(axis=0) + reach
        else:
            low_x, low_y, high_x, high_y = store.kernels.pose_box(poses)
            low, high = (low_x - reach, low_y - reach), (high_x + reach, high_y + reach)
        box = store.cell_box(low, high)
        # Python ints: a reading holds a handful of ids, and np.unique costs more than this.
        label_set = (sorted(set(labels.tolist())) if labels is not None and len(labels)
                     else None)
        ws = self._ws
        if ws is not None:
            # Cells are only registered when the working set is written back, so a box of
            # cells inside the gathered box holds no cell the working set lacks.
            gathered = self._box
            inside = (box[0] >= gathered[0] and box[1] >= gathered[1]
                      and box[2] <= gathered[2] and box[3] <= gathered[3])
            if inside and ws.free_slots >= count and self._holds_labels(ws, label_set):
                return self._ws if lazy else self.current
            # Writing back registers the cells of new landmarks: look the region up after it.
            self.flush()
        region = store.columns_in_box(low, high)
        # Known ids: also the cells holding each observed id, wherever it lies.
        extra = (store.label_columns(np.array(label_set, np.int64)) if label_set is not None
                 else None)
        columns = np.broadcast_to(region, (store.num_particles, len(region)))
        if extra is not None:
            in_region = np.zeros(max(store.num_cells, 1), dtype=bool)
            in_region[region] = True
            extra = np.where((extra >= 0) & ~in_region[np.maximum(extra, 0)], extra, -1)
            extra = np.sort(extra, axis=1)
            extra[:, 1:][extra[:, 1:] == extra[:, :-1]] = -1
            columns = np.concatenate([columns, extra], axis=1)
        self._ws = store.gather(columns, num_new_slots=NEW_SLOTS_PER_OBSERVATION
                                * max(count, 1))
        self._box = box
        self._labels = set() if label_set is None else set(label_set)
        return self._ws

    def _holds_labels(self, ws: WorkingSet, label_set) -> bool:
        """Known ids: every particle's landmark with one of these labels is in the working set
        (or not in the store). Each label is looked up once per working set."""
        if label_set is None:
            return True
        unseen = [label for label in label_set if label not in self._labels]
        if not unseen:
            return True
        if self.pending is not None:
            ws = self.current
        if not ws.covers(self.store.label_columns(np.array(unseen, np.int64))):
            return False
        self._labels.update(unseen)
        return True

    def entries_of(self, particle: int) -> tuple[WorkingSet | None, int]:
        """(the working set, the row holding particle ``particle``'s entries, ``pending``
        considered): one particle's entries without applying the resampling."""
        return self._ws, particle if self.pending is None else int(self.pending[particle])

    def took(self, ws: WorkingSet) -> None:
        """A lazy reading's working set, the pending resampling applied."""
        self._ws, self.pending = ws, None

    def created(self, columns: int) -> None:
        """This reading's first ``columns`` new-landmark columns now hold landmarks."""
        self.current.first_new_slot += columns

    def resample(self, indices: np.ndarray) -> None:
        """Particle m takes the working-set entries of particle ``indices[m]`` (with the
        compiled backend at the next reading, ``pending``)."""
        if self._ws is None:
            return
        if self.store.kernels is None:
            self._ws = self._ws.take(indices)
        else:
            self.pending = indices if self.pending is None else self.pending[indices]

    def flush(self) -> None:
        """Write the working set back into the store and drop it (a pending resampling is
        read through, not applied)."""
        if self._ws is not None:
            self.store.scatter(self._ws, self.track_labels, self.pending)
            self._ws = self.pending = None
