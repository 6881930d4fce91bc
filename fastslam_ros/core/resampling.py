# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Resampling schemes as pure functions returning the indices of the particles to keep.

The caller gathers its own stacked arrays with the indices (FilterPy's shape). ``weights`` must be
normalised and non-negative.
"""
from __future__ import annotations

import numpy as np


def _cumulative(weights: np.ndarray) -> np.ndarray:
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0  # guard against round-off leaving the last bin short
    return cumulative


def systematic_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One uniform offset, M evenly spaced pointers: lowest variance, O(M)."""
    count = len(weights)
    positions = (rng.random() + np.arange(count)) / count
    return np.searchsorted(_cumulative(weights), positions, side="right")


def batched_systematic_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling of every row of ``weights`` (K, P) (rows normalised) at once:
    indices (K, P) into each row; one uniform offset per row."""
    rows, count = weights.shape
    cumulative = np.cumsum(weights, axis=1)
    cumulative[:, -1] = 1.0
    offsets = np.arange(rows)[:, None]
    positions = (rng.random((rows, 1)) + np.arange(count)) / count + offsets
    flat = np.searchsorted((cumulative + offsets).ravel(), positions.ravel(), side="right")
    return np.clip(flat.reshape(rows, count) - offsets * count, 0, count - 1)


def stratified_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One uniform draw inside each of M equal strata."""
    count = len(weights)
    positions = (rng.random(count) + np.arange(count)) / count
    return np.searchsorted(_cumulative(weights), positions, side="right")


def multinomial_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """M independent draws (highest variance; the textbook baseline)."""
    positions = np.sort(rng.random(len(weights)))
    return np.searchsorted(_cumulative(weights), positions, side="right")


def residual_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """floor(M w) deterministic copies, the rest drawn multinomially from the residuals."""
    count = len(weights)
    copies = np.floor(count * weights).astype(np.int64)
    indices = np.repeat(np.arange(count), copies)
    remaining = count - len(indices)
    if remaining > 0:
        residual = count * weights - copies
        residual /= residual.sum()
        drawn = np.searchsorted(_cumulative(residual), rng.random(remaining), side="right")
        indices = np.concatenate([indices, np.sort(drawn)])
    return indices


RESAMPLERS = {
    "systematic": systematic_resample,
    "stratified": stratified_resample,
    "multinomial": multinomial_resample,
    "residual": residual_resample,
}


def effective_sample_size(weights: np.ndarray) -> float:
    """N_eff = 1 / sum(w^2) of normalised weights."""
    return float(1.0 / (weights @ weights))


def normalize_log_weights(log_weights: np.ndarray) -> tuple[np.ndarray, bool]:
    """Normalise with log-sum-exp; returns (normalised, underflow).

    If no weight is finite (every likelihood underflowed, or NaN came in), the weights are reset
    to uniform and ``underflow`` is True, so the filter stays finite and can say so.
    """
    peak = log_weights.max()
    if np.isnan(peak):
        log_weights = np.where(np.isnan(log_weights), -np.inf, log_weights)
        peak = log_weights.max()
    if not np.isfinite(peak):
        return np.full(log_weights.shape, -np.log(len(log_weights))), True
    shifted = log_weights - peak
    shifted -= np.log(np.exp(shifted).sum())
    return shifted, False
