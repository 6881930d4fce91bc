# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""numba twin of ``core/resampling.py``: systematic resampling, and the gathers of particle
rows it implies (poses, working-set rows)."""
from __future__ import annotations

import numpy as np
from numba import njit

from ..landmark_store import WorkingSet
from .jit import _JIT
from .reading import _copy_entries
from .records import Entries, entries_of


@njit(**_JIT)
def _systematic_kernel(weights, offset):
    count = weights.shape[0]
    cumulative = np.cumsum(weights)
    cumulative[count - 1] = 1.0  # as ``resampling._cumulative``
    indices = np.empty(count, np.int64)
    source = 0
    for m in range(count):
        # searchsorted(side="right") of the sorted positions: one merge pass.
        position = (offset + m) / count
        while source < count - 1 and cumulative[source] <= position:
            source += 1
        indices[m] = source
    return indices


@njit(**_JIT)
def _take_rows(indices, source):
    """source[indices] along the first axis, element by element (numba's slice copies are
    slower than numpy's)."""
    width = 1
    for extent in source.shape[1:]:
        width *= extent
    flat = source.reshape((source.shape[0], width))
    out = np.empty((indices.shape[0], flat.shape[1]), flat.dtype)
    for m in range(indices.shape[0]):
        row = indices[m]
        for i in range(flat.shape[1]):
            out[m, i] = flat[row, i]
    return out.reshape((indices.shape[0],) + source.shape[1:])


@njit(**_JIT)
def _take_kernel(indices, row, slot, block, state, ident, valid, dirty, is_new):
    return (_take_rows(indices, row), _take_rows(indices, slot), _take_rows(indices, block),
            _take_rows(indices, state), _take_rows(indices, ident), _take_rows(indices, valid),
            _take_rows(indices, dirty), _take_rows(indices, is_new))


def take(ws, indices: np.ndarray):
    """``WorkingSet.take``: the working set after resampling, its entries in one compiled
    pass (``columns``, which may be a read-only broadcast, by numpy)."""
    row, slot, block, state, ident, valid, dirty, is_new = _take_kernel(
        indices, ws.row, ws.slot, ws.block, ws.state, ws.ident, ws.valid, ws.dirty, ws.is_new)
    return WorkingSet(row, slot, block, ws.columns[indices], state, ident, valid, dirty, is_new,
                      ws.first_new_slot)


@njit(**_JIT)
def _reindex_kernel(indices, existing, table):
    """``_take_kernel`` in place on ``table`` (``Entries``) for non-decreasing ``indices``
    (systematic resampling's, and their compositions): rows that move up are copied in
    ascending order, rows that move down in descending order, so every source is read before
    it is overwritten; rows that keep their place are not touched, nor are the columns from
    ``existing`` on (empty in every particle). False, and nothing changed, for other
    indices."""
    table = Entries(*table)  # a plain tuple from Python (``records``)
    count = indices.shape[0]
    for m in range(1, count):
        if indices[m] < indices[m - 1]:
            return False
    for m in range(count):
        if indices[m] > m:
            _copy_entries(table, indices[m], table, m, existing)
    for m in range(count - 1, -1, -1):
        if indices[m] < m:
            _copy_entries(table, indices[m], table, m, existing)
    return True


def reindex(ws, indices: np.ndarray):
    """``take`` for a working set no longer needed as it was: in place when ``indices`` are
    non-decreasing (``_reindex_kernel``), else a copy."""
    if not _reindex_kernel(indices, ws.first_new_slot, tuple(entries_of(ws))):
        return take(ws, indices)
    ws.columns = ws.columns[indices]
    return ws


@njit(**_JIT)
def _resample_poses_kernel(weights, offset, poses, best):
    indices = _systematic_kernel(weights, offset)
    count = indices.shape[0]
    moved = np.empty((count, 3))
    copy = -1
    for m in range(count):
        source = indices[m]
        moved[m, 0], moved[m, 1], moved[m, 2] = poses[source, 0], poses[source, 1], \
            poses[source, 2]
        if copy < 0 and source == best:
            copy = m
    return indices, moved, copy


def resample_poses(weights: np.ndarray, rng: np.random.Generator, poses: np.ndarray,
                   best: int):
    """``resampling.systematic_resample`` (on the same weights and draw, the same indices) and
    what follows it in one call: (indices, the resampled poses, the first copy of particle
    ``best``, -1 when none was drawn)."""
    return _resample_poses_kernel(weights, rng.random(), poses, best)
