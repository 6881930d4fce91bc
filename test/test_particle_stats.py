# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""``people/particle_stats``: the same bits as numpy's plain forms of the same moments (the
pair these fast forms replace), so the tracker's estimates do not depend on which is used."""
from __future__ import annotations

import numpy as np
import pytest

from fastslam_ros.people.particle_stats import (particle_covariances, particle_means,
                                                 planar_distance, squared_planar_distance)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_moments_are_bit_identical_to_numpy_forms(seed):
    rng = np.random.default_rng(seed)
    clouds = rng.normal(rng.uniform(-50.0, 50.0, (40, 6, 1, 2)), rng.uniform(0.01, 2.0),
                        (40, 6, 50, 2))
    means = particle_means(clouds)
    assert np.array_equal(means, clouds.mean(axis=2))
    flat = clouds.reshape(-1, 50, 2)
    centred = flat - particle_means(flat)[:, None, :]
    assert np.array_equal(particle_covariances(centred),
                          np.einsum("kpi,kpj->kij", centred, centred) / 50)
    others = rng.normal(0.0, 30.0, (40, 6, 2))
    assert np.array_equal(planar_distance(means[:, :, None], others[:, None]),
                          np.linalg.norm(means[:, :, None] - others[:, None], axis=3))
    assert np.array_equal(squared_planar_distance(flat, others.reshape(-1, 1, 2)),
                          np.sum((flat - others.reshape(-1, 1, 2)) ** 2, axis=2))


def test_covariance_is_the_sample_covariance():
    rng = np.random.default_rng(7)
    cloud = rng.multivariate_normal([1.0, -2.0], [[0.5, 0.2], [0.2, 0.3]], 200_000)
    centred = cloud - cloud.mean(axis=0)
    np.testing.assert_allclose(particle_covariances(centred[None])[0],
                               np.cov(cloud.T, bias=True), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(particle_covariances(centred[None])[0],
                               [[0.5, 0.2], [0.2, 0.3]], atol=0.01)


def test_no_people():
    assert particle_means(np.zeros((0, 50, 2))).shape == (0, 2)
    assert particle_covariances(np.zeros((0, 50, 2))).shape == (0, 2, 2)
