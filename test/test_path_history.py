# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The shared-ancestry path history against every particle's path kept in full."""
from __future__ import annotations

import numpy as np
import pytest

from fastslam_ros.core.path_history import PathHistory


@pytest.mark.parametrize("particles", [1, 5, 40])
def test_paths_equal_the_full_copies_through_resampling_and_pruning(particles):
    rng = np.random.default_rng(particles)
    history = PathHistory(particles, prune_every=4, chain_capacity=10**6)
    paths: list[list[np.ndarray]] = [[] for _ in range(particles)]
    for step in range(400):
        poses = rng.normal(size=(particles, 3))
        history.record(float(step), poses)
        for particle in range(particles):
            paths[particle].append(poses[particle])
        if rng.random() < 0.5:
            # Sorted draws, and now and then a collapse onto one particle.
            indices = (np.sort(rng.integers(0, particles, particles)) if rng.random() < 0.7
                       else np.full(particles, int(rng.integers(0, particles))))
            history.resample(indices)
            paths = [list(paths[i]) for i in indices]
        if step % 37 == 0 or step == 399:
            for particle in range(particles):
                stamps, recorded = history.path(particle)
                np.testing.assert_array_equal(recorded, np.array(paths[particle]))
                np.testing.assert_array_equal(stamps, np.arange(step + 1, dtype=float))
