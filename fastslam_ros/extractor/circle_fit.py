# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Algebraic circle fits of many point sets at once (Taubin's fit, Chernov's Newton solution).

Taubin (1991) minimises the algebraic distance sum (x^2 + y^2 + D x + E y + F)^2 normalised by
its mean squared gradient, which makes it nearly free of the small-radius bias of Kasa's fit on
the short arcs a laser sees of a pole. After centring each set on its centroid, the fit is the
smallest root eta of a cubic in the set's moments; Newton's method from eta = 0 reaches it
monotonically (Chernov, "Circular and linear regression", 2010, CircleFitByTaubin). The sets
are concatenated and cut by ``starts`` (as ``numpy.add.reduceat``), so every step is one numpy
operation over all sets.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

NEWTON_STEPS = 20
"""Newton steps on the cubic; it converges in a handful from eta = 0 (each step is checked)."""


@dataclass
class CircleFits:
    """Per point set (S,): centre ``x``, ``y`` and ``radius`` (m; inf for collinear points),
    ``residual`` (RMS distance of the points from the circle) and ``line_residual`` (RMS
    distance from their best straight line)."""

    x: np.ndarray
    y: np.ndarray
    radius: np.ndarray
    residual: np.ndarray
    line_residual: np.ndarray


def segment_means(values: np.ndarray, starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Mean of ``values`` over each run [starts[i], starts[i] + counts[i])."""
    return np.add.reduceat(values, starts) / counts


def fit_circles(x: np.ndarray, y: np.ndarray, starts: np.ndarray) -> CircleFits:
    """Taubin circle fits of the point sets ``x[starts[i]:starts[i+1]]`` (each >= 3 points)."""
    counts = np.diff(np.append(starts, len(x)))
    owner = np.repeat(np.arange(len(starts)), counts)
    mean_x, mean_y = segment_means(x, starts, counts), segment_means(y, starts, counts)
    dx, dy = x - mean_x[owner], y - mean_y[owner]
    dz = dx * dx + dy * dy
    mxx, myy = segment_means(dx * dx, starts, counts), segment_means(dy * dy, starts, counts)
    mxy = segment_means(dx * dy, starts, counts)
    mxz, myz = segment_means(dx * dz, starts, counts), segment_means(dy * dz, starts, counts)
    mzz = segment_means(dz * dz, starts, counts)
    mz = mxx + myy
    cov_xy = mxx * myy - mxy * mxy
    var_z = mzz - mz * mz
    a3, a2 = 4.0 * mz, -3.0 * mz * mz - mzz
    a1 = var_z * mz + 4.0 * cov_xy * mz - mxz * mxz - myz * myz
    a0 = mxz * (mxz * myy - myz * mxy) + myz * (myz * mxx - mxz * mxy) - var_z * cov_xy
    eta, value = np.zeros_like(mz), a0.copy()
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for _ in range(NEWTON_STEPS):
            slope = a1 + eta * (2.0 * a2 + 3.0 * a3 * eta)
            step = eta - value / slope
            new_value = a0 + step * (a1 + step * (a2 + step * a3))
            better = np.isfinite(step) & (np.abs(new_value) < np.abs(value))
            if not better.any():
                break
            eta, value = np.where(better, step, eta), np.where(better, new_value, value)
        det = 2.0 * (eta * eta - eta * mz + cov_xy)
        centre_x = (mxz * (myy - eta) - myz * mxy) / det
        centre_y = (myz * (mxx - eta) - mxz * mxy) / det
        radius = np.sqrt(centre_x * centre_x + centre_y * centre_y + mz)
        collinear = ~(np.isfinite(radius) & (det != 0.0))
        radius = np.where(collinear, np.inf, radius)
        centre_x, centre_y = np.where(collinear, 0.0, centre_x), np.where(collinear, 0.0, centre_y)
        distance = np.hypot(dx - centre_x[owner], dy - centre_y[owner]) - radius[owner]
        residual = np.sqrt(segment_means(distance * distance, starts, counts))
    half_trace = 0.5 * (mxx + myy)
    smallest = half_trace - np.sqrt((0.5 * (mxx - myy)) ** 2 + mxy * mxy)
    line_residual = np.sqrt(np.clip(smallest, 0.0, None))
    return CircleFits(centre_x + mean_x, centre_y + mean_y, radius, residual, line_residual)
