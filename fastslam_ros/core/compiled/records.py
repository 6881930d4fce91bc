# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The records the compiled reading passes between its kernels: named tuples of arrays, which
numba passes as one argument and reads by field (M particles, K observations, W working-set
columns).

A kernel called from Python takes its records as plain tuples and names them first
(``Entries(*table)``): numba types a plain tuple from Python in its C dispatcher, a named one
in Python, which costs tens of microseconds a reading."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .jit import _JIT


class Entries(NamedTuple):
    """A working set's per-entry arrays (``WorkingSet``'s), all (M, W) but ``state`` (M, W, 6)
    and ``ident`` (M, W, 2)."""

    row: np.ndarray
    slot: np.ndarray
    block: np.ndarray
    state: np.ndarray
    ident: np.ndarray
    valid: np.ndarray
    dirty: np.ndarray
    is_new: np.ndarray


def entries_of(ws) -> Entries:
    """The ``Entries`` of a ``WorkingSet``."""
    return Entries(ws.row, ws.slot, ws.block, ws.state, ws.ident, ws.valid, ws.dirty, ws.is_new)


class Particles(NamedTuple):
    """The particles as a reading finds them."""

    poses: np.ndarray
    """(M, 3) their poses."""
    log_weights: np.ndarray
    """(M,) their log weights."""
    mean: np.ndarray
    """(M, 3) the pose the observations are scored at (FastSLAM 2.0: the prior's mean)."""
    cov: np.ndarray
    """(M, 3, 3) its covariance (``ReadingPlan.has_cov``; else a (1, 3, 3) stand-in)."""


class Observations(NamedTuple):
    """A reading's usable observations (K,)."""

    ranges: np.ndarray
    bearings: np.ndarray
    labels: np.ndarray
    range_variance: np.ndarray
    """Each range's variance (``FastSLAM._noise``)."""
    creator: np.ndarray
    """The observation whose landmark each one creates (itself; with known ids the first of
    its id)."""


class Draws(NamedTuple):
    """The reading's random draws, drawn by the caller in the numpy path's order."""

    uniforms: np.ndarray
    """(K * M) uniforms of ``monte_carlo``."""
    normals: np.ndarray
    """(M, 3) standard normals of the proposal's draw."""


class PendingResampling(NamedTuple):
    """A resampling not yet applied to the working set: particle m of the reading takes the
    entries of ``source``'s particle ``order[m]`` (none when ``order`` is empty)."""

    order: np.ndarray
    source: Entries


class DeferredMotion(NamedTuple):
    """FastSLAM 2.0's odometry whose covariance the reading propagates (``advance_mean``)."""

    turn: np.ndarray
    """(M, 2) cosine and sine of each heading after the first rotation."""
    cov: np.ndarray
    """(M, 3, 3) the covariance moved from (``ReadingPlan.prior_has_cov``; else a stand-in)."""
    terms: np.ndarray
    """(6,) rot1, trans, rot2 and their variances."""


class ReadingOutputs(NamedTuple):
    """What the reading's particles write, each its own column or row."""

    choice: np.ndarray
    """(K, M) working-set column of each observation's landmark, or ``NEW`` / ``IGNORE``."""
    factor: np.ndarray
    """(K, M) log weight factors."""
    poses: np.ndarray
    """(M, 3) the new poses."""
    log_weights: np.ndarray
    """(M,) the new log weights (normalised by ``_settle``)."""
    fresh: np.ndarray
    """(K, M, 5) mean and packed covariance of each landmark created."""
    finite: np.ndarray
    """(M,) the particle's update is finite."""
    recorded: np.ndarray
    """(M, 3) the path history's next generation, given the new poses."""


class NewLandmarks(NamedTuple):
    """Where a reading's new landmarks go (``_assign_columns``)."""

    creating: np.ndarray
    """(K, M) the pair creates a landmark."""
    column: np.ndarray
    """(K,) working-set column of the landmark an observation creates (-1: none)."""
    keys: np.ndarray
    """(K, M) key of each landmark created (-1: none)."""


class Scratch(NamedTuple):
    """One thread's buffers for a particle of the reading (``scratch``)."""

    local: np.ndarray
    """(W,) the candidates' columns."""
    log_lik: np.ndarray
    """(K, W) log likelihood of each observation against each candidate."""
    mahalanobis: np.ndarray
    """(K, W) their squared Mahalanobis distances."""
    terms: np.ndarray
    """(W, 5) each candidate pair's (dx, dy, q, r, predicted bearing)."""
    picked: np.ndarray
    """(K,) the row of ``terms`` of each observation's choice."""
    pick: np.ndarray
    value: np.ndarray
    order: np.ndarray
    cumulative: np.ndarray
    inverse_q: np.ndarray
    """(K,) log(1 / q) of each association."""
    robust: np.ndarray
    """(K,) the outlier test's correction of the inliers."""
    info: np.ndarray
    b: np.ndarray
    a: np.ndarray
    cof: np.ndarray
    full: np.ndarray
    sigma: np.ndarray
    observed: np.ndarray
    """(W,) the particle observed the column's landmark."""


@njit(**_JIT)
def scratch(count, width):
    """``Scratch`` for ``count`` observations and ``width`` (>= 1) columns."""
    return Scratch(np.empty(width, np.int64), np.empty((count, width)),
                   np.empty((count, width)), np.empty((width, 5)), np.empty(count, np.int64),
                   np.empty(count, np.int64), np.empty(count), np.empty(width, np.int64),
                   np.empty(width + 1), np.empty(count), np.empty(count), np.empty(9),
                   np.empty(3), np.empty(9), np.empty(9), np.empty(9), np.empty(9),
                   np.empty(width, np.bool_))
