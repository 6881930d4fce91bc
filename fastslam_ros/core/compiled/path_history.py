# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""numba twin of ``core/path_history.py``: the pruning of the shared path tree."""
from __future__ import annotations

import numpy as np
from numba import njit

from .jit import _JIT


@njit(**_JIT)
def _ranks(values):
    """(the distinct values, sorted; each value's index among them) of non-negative integers:
    ``np.unique`` and ``np.searchsorted`` on it, through a marker."""
    size = 0
    for v in values:
        size = max(size, v + 1)
    rank = np.zeros(size, np.int64)
    for v in values:
        rank[v] = 1
    count = 0
    for i in range(size):
        if rank[i]:
            rank[i] = count
            count += 1
    distinct = np.empty(count, np.int64)
    positions = np.empty(values.shape[0], np.int64)
    for k in range(values.shape[0]):
        positions[k] = rank[values[k]]
        distinct[positions[k]] = values[k]
    return distinct, positions


@njit(**_JIT)
def _prune_kernel(leaf, parents, poses, widths, count):
    """``PathHistory._prune_generations_numpy`` in place: the kept nodes of each of the first
    ``count`` generations moved to its start (in their order, so no node is overwritten
    before it is read); returns the new leaf."""
    alive, new_leaf = _ranks(leaf)
    for g in range(count - 1, -1, -1):
        width = alive.shape[0]
        chosen = np.empty(width, np.int64)
        for i in range(width):
            source = alive[i]
            chosen[i] = parents[g, source]
            poses[g, i, 0], poses[g, i, 1], poses[g, i, 2] = (poses[g, source, 0],
                                                              poses[g, source, 1],
                                                              poses[g, source, 2])
        alive, positions = _ranks(chosen)
        for i in range(width):
            parents[g, i] = positions[i]
        widths[g] = width
    return new_leaf


def prune(leaf: np.ndarray, parents: np.ndarray, poses: np.ndarray, widths: np.ndarray,
          count: int) -> np.ndarray:
    """``PathHistory._prune_generations_numpy`` in one call on the history's arrays (parents
    (G, M), poses (G, M, 3), widths (G,), changed in place; the first ``count`` generations);
    returns the new leaf."""
    return _prune_kernel(leaf, parents, poses, widths, count)
