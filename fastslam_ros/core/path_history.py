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


class PathHistory:
    """Ancestry tree of particle poses with periodic pruning of dead branches."""

    def __init__(self, num_particles: int, prune_every: int = 32,
                 chain_capacity: int = CHAIN_CAPACITY, kernels=None) -> None:
        self.num_particles = num_particles
        self.kernels = kernels
        """The compiled backend (``core.kernels``, which then prunes) or None."""
        self.prune_every = prune_every
        self.chain_capacity = max(chain_capacity, 2 * prune_every)
        self._chain_stamps = np.zeros(0)
        self._chain_poses = np.zeros((0, 3))
        self._stamps: list[float] = []
        self._poses: list[np.ndarray] = []
        self._parents: list[np.ndarray] = []
        self.leaf = np.zeros(num_particles, dtype=np.int64)
        self._identity = np.arange(num_particles)
        self._next_prune = 2 * prune_every

    def __len__(self) -> int:
        return len(self._chain_stamps) + len(self._stamps)

    def record(self, stamp: float, poses: np.ndarray) -> None:
        """Append the particles' current poses as a new generation."""
        self._stamps.append(float(stamp))
        self._poses.append(np.array(poses, dtype=float))
        self._parents.append(self.leaf)          # never changed in place: replaced instead
        self.leaf = self._identity
        if len(self._stamps) >= self._next_prune:
            self._prune()
            # Doubling keeps pruning amortised O(1) even if the particles never coalesce.
            self._next_prune = len(self._stamps) + max(self.prune_every, len(self._stamps))

    def resample(self, indices: np.ndarray) -> None:
        """Particle m now continues the path of particle ``indices[m]``."""
        self.leaf = self.leaf[indices]

    def path(self, particle: int) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (T,), poses (T, 3)) of one particle, oldest first."""
        node = int(self.leaf[particle])
        tail = []
        for generation in range(len(self._stamps) - 1, -1, -1):
            tail.append(self._poses[generation][node])
            node = int(self._parents[generation][node])
        poses = np.concatenate([self._chain_poses, np.reshape(tail[::-1], (-1, 3))])
        return np.concatenate([self._chain_stamps, self._stamps]), poses

    def _prune(self) -> None:
        """Drop nodes no particle descends from; move single-ancestor generations to the chain."""
        if self.kernels is not None:
            self._prune_generations(self.kernels)
        else:
            self._prune_generations_numpy()
        single = [len(p) == 1 for p in self._poses]
        # Generations older than the newest single-node one form one chain.
        cut = max((i + 1 for i, is_single in enumerate(single) if is_single), default=0)
        keep_from = min(cut, len(self._stamps) - self.prune_every)
        if keep_from > 0 and all(single[:keep_from]):
            self._extend_chain(np.array(self._stamps[:keep_from]),
                               np.array([p[0] for p in self._poses[:keep_from]]))
            del self._stamps[:keep_from], self._poses[:keep_from], self._parents[:keep_from]
            self._parents[0] = np.zeros_like(self._parents[0])

    def _prune_generations_numpy(self) -> None:
        """Keep only the nodes some particle descends from, renumbered in their order."""
        alive = np.unique(self.leaf)
        self.leaf = np.searchsorted(alive, self.leaf)
        for generation in range(len(self._stamps) - 1, -1, -1):
            parents = self._parents[generation][alive]
            self._poses[generation] = self._poses[generation][alive]
            if len(parents) == 1:
                # One node (the particles have coalesced): nothing to sort or look up.
                alive, self._parents[generation] = parents, np.zeros(1, np.int64)
                continue
            alive = np.unique(parents)
            self._parents[generation] = np.searchsorted(alive, parents)

    def _prune_generations(self, kernels) -> None:
        """``_prune_generations_numpy`` in one compiled call."""
        self.leaf, self._parents, self._poses = kernels.prune(self.leaf, self._parents,
                                                             self._poses)

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
