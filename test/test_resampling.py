# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Resampling schemes: expected copy counts, variance ordering, N_eff, log-weight handling."""
from __future__ import annotations

import numpy as np
import pytest

from fastslam_ros.core.resampling import (RESAMPLERS, effective_sample_size,
                                          normalize_log_weights, residual_resample,
                                          stratified_resample, systematic_resample)


def random_weights(rng, count):
    w = rng.gamma(0.5, size=count)
    return w / w.sum()


@pytest.mark.parametrize("name", sorted(RESAMPLERS))
def test_counts_are_unbiased(name):
    """E[copies of i] = M w_i for every scheme (averaged over many draws)."""
    rng = np.random.default_rng(0)
    weights = random_weights(rng, 20)
    draws = 4000
    counts = np.zeros(20)
    for _ in range(draws):
        indices = RESAMPLERS[name](weights, rng)
        assert len(indices) == 20 and indices.min() >= 0 and indices.max() < 20
        counts += np.bincount(indices, minlength=20)
    expected = 20 * weights
    # Per-particle copies have variance <= M w (1 - w) (multinomial bound); 5 sigma on the mean.
    tolerance = 5 * np.sqrt(expected * (1 - weights) / draws) + 1e-9
    assert np.all(np.abs(counts / draws - expected) <= tolerance)


@pytest.mark.parametrize("scheme", [systematic_resample, residual_resample])
def test_low_variance_schemes_keep_floor_and_ceiling(scheme):
    """Systematic and residual give every particle at least floor(M w) copies; systematic at
    most ceil(M w)."""
    rng = np.random.default_rng(1)
    for _ in range(200):
        weights = random_weights(rng, 30)
        copies = np.bincount(scheme(weights, rng), minlength=30)
        assert np.all(copies >= np.floor(30 * weights) - 1e-9)
        if scheme is systematic_resample:
            assert np.all(copies <= np.ceil(30 * weights) + 1e-9)


def test_stratified_has_lower_variance_than_multinomial():
    rng = np.random.default_rng(2)
    weights = random_weights(rng, 50)
    def spread(scheme):
        counts = np.array([np.bincount(scheme(weights, rng), minlength=50) for _ in range(2000)])
        return counts.var(axis=0).sum()
    assert spread(stratified_resample) < spread(RESAMPLERS["multinomial"])


def test_uniform_weights_keep_every_particle_with_systematic():
    rng = np.random.default_rng(3)
    np.testing.assert_array_equal(systematic_resample(np.full(10, 0.1), rng), np.arange(10))


def test_effective_sample_size_closed_forms():
    assert effective_sample_size(np.full(8, 1 / 8)) == pytest.approx(8)
    assert effective_sample_size(np.array([1.0, 0, 0, 0])) == pytest.approx(1)
    assert effective_sample_size(np.array([0.5, 0.5, 0, 0])) == pytest.approx(2)


def test_normalize_log_weights_survives_underflow_and_nan():
    normalized, underflow = normalize_log_weights(np.array([-1e4, -1e4 - np.log(3)]))
    np.testing.assert_allclose(np.exp(normalized), [0.75, 0.25])
    assert not underflow
    normalized, underflow = normalize_log_weights(np.array([-np.inf, np.nan, -np.inf]))
    assert underflow
    np.testing.assert_allclose(np.exp(normalized), [1 / 3] * 3)
    # One NaN among finite weights: that particle gets weight zero, the others are kept.
    normalized, underflow = normalize_log_weights(np.array([0.0, np.nan, np.log(3)]))
    assert not underflow
    np.testing.assert_allclose(np.exp(normalized), [0.25, 0.0, 0.75])
