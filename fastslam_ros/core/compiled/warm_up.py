# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Compiles every kernel of the numba twins once (or loads it from numba's cache), so that
compilation never lands on the first reading."""
from __future__ import annotations

import time

import numpy as np

from ..landmark_store import LandmarkStore, WorkingSet
from .landmark_store import (_gather, block_records, claim, claim_plan, dirty_pairs,
                             insertion_pairs, new_entries, place, write_back)
from .motion import advance_mean, propagate_cov, sample_motion
from .path_history import prune
from .proposal import sample_pose
from .reading import _update, pose_box, usable_observations
from .records import Draws, Particles
from .resampling import reindex, resample_poses, take
from .settings import MODE_CODES, reading_settings


_warm = False


def warm_up() -> float:
    """Compile every kernel (or load it from the cache) on a tiny reading; seconds taken.

    The filter calls it at construction, so no reading pays for compilation; later calls
    return at once.
    """
    global _warm
    if _warm:
        return 0.0
    from ..config import FastSLAMConfig  # noqa: PLC0415 (no import cycle at module load)
    from ..motion import OdometryControl
    from ..observation import SensorOffset
    start = time.perf_counter()
    m, width = 2, 5
    poses = np.zeros((m, 3))
    cov = np.tile(np.eye(3) * 0.01, (m, 1, 1))
    ranges, bearings = np.array([1.0, 2.0]), np.array([0.0, 0.1])
    labels = np.array([0, 1], np.int64)
    offset = SensorOffset(0.1, 0.0, 0.0)
    for mode in MODE_CODES:
        settings = reading_settings(FastSLAMConfig(association=mode), offset, -5.0, -np.inf,
                                    10.0)
        for pose_cov in (None, cov):
            state = np.zeros((m, width, 6))
            state[:, :2, 0] = [1.0, 2.0]
            state[:, :, 2] = state[:, :, 4] = 1.0
            ws = WorkingSet(row=np.full((m, width), -1, np.int64),
                            slot=np.zeros((m, width), np.int64),
                            block=np.full((m, width), -1, np.int64),
                            columns=np.zeros((m, 0), np.int64), state=state,
                            ident=np.zeros((m, width, 2), np.int64),
                            valid=np.array([[True, True, False, False, False]] * m),
                            dirty=np.zeros((m, width), bool),
                            is_new=np.zeros((m, width), bool), first_new_slot=2)
            # On the calling thread and split over threads (M >= PARALLEL_MIN_PARTICLES; its
            # chunk kernel is called by Python), with and without a pending resampling.
            for threads, order in ((1, None), (2, np.array([1, 0]))):
                _update(ws, Particles(poses, np.zeros(m), poses, pose_cov),
                        (ranges, bearings, labels), Draws(np.full(2 * m, 0.5), np.zeros((m, 3))),
                        settings, 5.0, 0, pose_cov is not None, np.empty((m, 3)), order, threads)
    sample_pose(poses, cov, np.zeros((m, 3)))
    usable_observations(ranges, bearings, labels, True, 1e-3)
    pose_box(poses)
    advance_mean(None, poses, (0.1, 0.2, 0.0), settings)
    _, _, turn, motion = advance_mean((poses, cov), poses, (0.1, 0.2, 0.0), settings)
    propagate_cov(turn, None, motion)
    propagate_cov(turn, cov, motion)
    sample_motion(poses, OdometryControl(0.1, 0.2, 0.0), np.full(3, 0.01), np.zeros((m, 3)))
    indices, _, _ = resample_poses(np.full(m, 1.0 / m), np.random.default_rng(0), poses, 0)
    take(ws, indices)
    reindex(ws, indices)
    reindex(ws, indices[::-1].copy())
    prune(np.zeros(m, np.int64), np.zeros((2, m), np.int64), np.zeros((2, m, 3)),
          np.full(2, m, np.int64), 2)
    store = LandmarkStore(m, 5.0)
    for threads in (1, 2):
        _gather(store, np.zeros((m, 1), np.int64), 2, threads)
    block_records(store.table[0], store.occupied, store.state, store.ident)
    pairs = np.zeros(1, np.int64)
    rows, needed, _ = claim_plan(store.table, pairs, pairs, store.refcount)
    claim(store.table, pairs, pairs, rows, needed, np.zeros(1, np.int64), store.refcount,
          store.state, store.ident, store.occupied)
    origin = np.arange(m)
    pair_particles, pair_blocks = dirty_pairs(ws, origin)
    write_back(ws, pair_particles, pair_blocks, np.zeros(0, np.int64), store.state,
               store.occupied, origin)
    ws.is_new[:, 0] = True
    owner, entry, ix, _, keys, _ = new_entries(ws, 5.0, 0, origin)
    pending = np.arange(len(owner))
    _, pair_column, inverse, rank = insertion_pairs(owner, ix, pending, 4)
    place(ws, owner, entry, keys, origin, pending, np.zeros(len(pair_column), np.int64),
          inverse, rank, store.state, store.ident, store.occupied)
    _warm = True
    return time.perf_counter() - start
