# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Moments of the people's particle clouds and planar distances, written once.

The clouds are (..., M_p, 2) arrays: a reduction over M_p with 2 values per particle is one of
numpy's slow strided cases (for 1,000 clouds of 50, ``mean(axis=-2)`` takes about 4 times and
``einsum("kpi,kpj->kij")`` about 18 times as long as the einsums below). These give the same
bits as those forms (the same products, summed in the same order), so the tracker's results do
not depend on which is used.
"""
from __future__ import annotations

import numpy as np


def particle_means(particles: np.ndarray) -> np.ndarray:
    """Mean (..., 2) of clouds (..., M_p, 2)."""
    return np.einsum("...pi->...i", particles) / particles.shape[-2]


def particle_covariances(centred: np.ndarray) -> np.ndarray:
    """Covariance (K, 2, 2) of clouds whose means were subtracted, ``centred`` (K, M_p, 2)
    (the maximum-likelihood estimate: divided by M_p)."""
    x, y = centred[..., 0], centred[..., 1]
    count = max(centred.shape[-2], 1)
    xy = np.einsum("kp,kp->k", x, y) / count
    covariance = np.empty((len(centred), 2, 2))
    covariance[:, 0, 0] = np.einsum("kp,kp->k", x, x) / count
    covariance[:, 0, 1] = xy
    covariance[:, 1, 0] = xy
    covariance[:, 1, 1] = np.einsum("kp,kp->k", y, y) / count
    return covariance


def squared_planar_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Squared Euclidean distance between the points ``a`` and ``b`` (..., 2), broadcast."""
    dx = a[..., 0] - b[..., 0]
    dy = a[..., 1] - b[..., 1]
    return dx * dx + dy * dy


def planar_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euclidean distance between the points ``a`` and ``b`` (..., 2), broadcast."""
    return np.sqrt(squared_planar_distance(a, b))
