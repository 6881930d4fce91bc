# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Every particle's path s_1:t stored once per ancestor (shared ancestry, not M path copies).

Each update appends one generation: the M poses and, for each, the index of its parent in the
previous generation. Resampling only permutes ``leaf``. Generations whose nodes all descend from
a single ancestor are moved to a plain chain, so memory grows with the path length, not with M.
The chain holds at most ``chain_capacity`` poses: when full, its older half is thinned to every
other pose, so memory stays bounded over any run length while the recent path keeps every pose.
"""
from __future__ import annotations

import math

import numpy as np

CHAIN_CAPACITY = 1 << 15
"""Poses the shared chain keeps at most (32,768: 1 MiB; 1.8 h of readings at 5 Hz in full)."""


def _filled(shape: tuple[int, ...], dtype) -> np.ndarray:
    """Zeros whose memory is written now: the first write to fresh pages (lazily mapped by
    ``np.zeros``) is what costs, so it happens here and not while recording."""
    array = np.empty(shape, dtype)
    array.fill(0)
    return array


class PathHistory:
    """Ancestry tree of particle poses with periodic pruning of dead branches.

    Generation g (oldest first, ``len(self) - len(chain)`` of them) holds ``widths[g]`` nodes:
    their poses ``poses[g, :widths[g]]`` and the index of each one's parent in generation
    g - 1 ``parents[g, :widths[g]]``, in arrays allocated for ``M`` nodes per generation (grown
    by doubling), so recording a generation and pruning copy no array of arrays.
    """

    def __init__(self, num_particles: int, prune_every: int = 32,
                 chain_capacity: int = CHAIN_CAPACITY, prune=None) -> None:
        self.num_particles = num_particles
        self.compiled_prune = prune
        """The compiled pruning (``compiled.prune``), or None: ``_prune_generations_numpy``."""
        self.prune_every = prune_every
        self.chain_capacity = max(chain_capacity, 2 * prune_every)
        self._chain_stamps = np.zeros(0)
        self._chain_poses = np.zeros((0, 3))
        self._count = 0
        """Generations held (the first ``_count`` entries of the arrays below)."""
        capacity = 4 * prune_every
        self._stamps = _filled((capacity,), float)
        self._poses = _filled((capacity, num_particles, 3), float)
        self._parents = _filled((capacity, num_particles), np.int64)
        self._widths = _filled((capacity,), np.int64)
        self.leaf = np.zeros(num_particles, dtype=np.int64)
        self._identity = np.arange(num_particles)
        self._next_prune = 2 * prune_every

    def __len__(self) -> int:
        return len(self._chain_stamps) + self._count

    def next_generation(self) -> np.ndarray:
        """(M, 3) the poses of the generation ``record`` appends next, for a caller that
        writes them there itself (``record(stamp, written=True)``)."""
        if self._count == len(self._stamps):
            self._grow()
        return self._poses[self._count]

    def record(self, stamp: float, poses: np.ndarray | None = None,
               written: bool = False) -> None:
        """Append the particles' current poses as a new generation (``written``: already
        written into ``next_generation()``)."""
        g = self._count
        if g == len(self._stamps):
            self._grow()
        self._stamps[g] = stamp
        if not written:
            self._poses[g] = poses
        self._parents[g] = self.leaf
        self._widths[g] = self.num_particles
        self._count = g + 1
        self.leaf = self._identity          # never changed in place: replaced instead
        if self._count >= self._next_prune:
            self._prune()
            # Doubling keeps pruning amortised O(1) even if the particles never coalesce.
            self._next_prune = self._count + max(self.prune_every, self._count)

    def _grow(self) -> None:
        """Twice the room for generations."""
        count = self._count

        def doubled(array: np.ndarray) -> np.ndarray:
            grown = _filled((2 * len(array),) + array.shape[1:], array.dtype)
            grown[:count] = array[:count]
            return grown

        self._stamps, self._poses = doubled(self._stamps), doubled(self._poses)
        self._parents, self._widths = doubled(self._parents), doubled(self._widths)

    def resample(self, indices: np.ndarray) -> None:
        """Particle m now continues the path of particle ``indices[m]``."""
        self.leaf = self.leaf[indices]

    def generations(self) -> list[tuple[float, np.ndarray, np.ndarray]]:
        """(stamp, parents (W,), poses (W, 3)) of every generation, oldest first (views)."""
        return [(float(self._stamps[g]), self._parents[g, :w], self._poses[g, :w])
                for g, w in enumerate(self._widths[:self._count].tolist())]

    def path(self, particle: int) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (T,), poses (T, 3)) of one particle, oldest first."""
        count = self._count
        nodes = np.empty(count, np.int64)
        node = int(self.leaf[particle])
        parents = self._parents
        for generation in range(count - 1, -1, -1):
            nodes[generation] = node
            node = int(parents[generation, node])
        poses = np.concatenate([self._chain_poses, self._poses[np.arange(count), nodes]])
        return np.concatenate([self._chain_stamps, self._stamps[:count]]), poses

    def _prune(self) -> None:
        """Drop nodes no particle descends from; move single-ancestor generations to the chain."""
        count = self._count
        if self.compiled_prune is not None:
            self.leaf = self.compiled_prune(self.leaf, self._parents, self._poses, self._widths,
                                            count)
        else:
            self._prune_generations_numpy()
        single = self._widths[:count] == 1
        # Generations older than the newest single-node one form one chain.
        cut = int(single.nonzero()[0][-1]) + 1 if single.any() else 0
        keep_from = min(cut, count - self.prune_every)
        if keep_from > 0 and single[:keep_from].all():
            self._extend_chain(self._stamps[:keep_from].copy(),
                               self._poses[:keep_from, 0].copy())
            rest = count - keep_from
            width = int(self._widths[keep_from:count].max())
            for array in (self._stamps, self._widths):
                array[:rest] = array[keep_from:count]
            for array in (self._poses, self._parents):
                array[:rest, :width] = array[keep_from:count, :width]
            self._parents[0] = 0
            self._count = rest

    def _prune_generations_numpy(self) -> None:
        """Keep only the nodes some particle descends from, renumbered in their order, at the
        start of their generation."""
        alive = np.unique(self.leaf)
        self.leaf = np.searchsorted(alive, self.leaf)
        for generation in range(self._count - 1, -1, -1):
            width = len(alive)
            parents = self._parents[generation, alive]
            self._poses[generation, :width] = self._poses[generation, alive]
            self._widths[generation] = width
            if width == 1:
                # One node (the particles have coalesced): nothing to sort or look up.
                alive, self._parents[generation, 0] = parents, 0
                continue
            alive = np.unique(parents)
            self._parents[generation, :width] = np.searchsorted(alive, parents)

    def _extend_chain(self, stamps: np.ndarray, poses: np.ndarray) -> None:
        """Append to the chain; thin its older half while it would exceed the capacity."""
        stamps = np.concatenate([self._chain_stamps, stamps])
        poses = np.concatenate([self._chain_poses, poses])
        while len(stamps) > self.chain_capacity:
            half = len(stamps) // 2
            keep = np.concatenate([np.arange(0, half, 2), np.arange(half, len(stamps))])
            stamps, poses = stamps[keep], poses[keep]
        self._chain_stamps, self._chain_poses = stamps, poses


def decimation(length: int, limit: int) -> np.ndarray | None:
    """Indices of at most ``limit`` of ``length`` items, evenly spread and ending at the last;
    None when all fit. The stride is a power of two, so the kept items stay the same from one
    call to the next while the sequence grows (their messages are reused)."""
    if length <= limit:
        return None
    stride = 1 << math.ceil(math.log2((length - 1) / max(limit - 2, 1)))
    indices = np.arange(0, length, stride)
    return indices if indices[-1] == length - 1 else np.append(indices, length - 1)
