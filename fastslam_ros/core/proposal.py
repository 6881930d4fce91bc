# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""FastSLAM 2.0: the pose proposal that uses the current observations, and its weight.

With the motion model linearised as s_t ~ N(s_hat, P) and observation k linearised in the pose
(G_k) and its landmark, the textbook proposal for one observation is

    Sigma_s = (G^T Q^-1 G + P^-1)^-1
    mu_s    = Sigma_s G^T Q^-1 (z - z_hat) + s_hat,     Q = G_m Sigma_m G_m^T + R,

with importance weight N(z; z_hat, L), L = G P G^T + Q. Several observations of one reading
refine the proposal one after another and their weights multiply. With every Jacobian taken at
the same linearisation point, those sequential updates sum to one information update

    J = sum_k G_k^T Q_k^-1 G_k,   b = sum_k G_k^T Q_k^-1 nu_k,
    Sigma_s = (I + P J)^-1 P,     mu_s = s_hat + Sigma_s b,

(= (P^-1 + J)^-1 without inverting P, which is singular when the robot stands still), and the
product of the sequential weights is the joint likelihood of all innovations, which the matrix
inversion and determinant lemmas give from the same 3x3 quantities:

    nu^T L^-1 nu = sum_k nu_k^T Q_k^-1 nu_k - b^T Sigma_s b,
    det L        = prod_k det Q_k * det(I + P J).

So the whole reading costs a fixed number of array operations over (particles, observations),
not a loop over observations. Every Jacobian is taken at the predicted mean s_hat.

The per-observation 2x2 terms are written out component by component (numpy's stacked inv and
det cost ~30x more per tiny matrix than a few elementwise operations), and one ``einsum`` each
forms and sums J, b and the quadratic form over the observations.
"""
from __future__ import annotations

import numpy as np

from .geometry import LOG_TWO_PI, wrap_angle
from .landmark_ekf import innovation_covariance
from .observation import SensorOffset, heading_column, observation_terms

POSE_JITTER = 1e-12
"""Variance added to the proposal diagonal before factorising it (sigma 1e-6 m, rad)."""


def observation_proposal(mean: np.ndarray, cov: np.ndarray, landmarks: np.ndarray,
                         ranges: np.ndarray, bearings: np.ndarray, used: np.ndarray,
                         offset: SensorOffset, noise_diag):
    """The proposal N(mu_s, Sigma_s) and log weight for n particles.

    mean (n, 3) and cov (n, 3, 3): the motion prior N(s_hat, P). Observations and particles meet
    in a dense (K, n) layout: where ``used[k, m]``, observation k of particle m, ``ranges`` and
    ``bearings`` (broadcasting against (K, n), e.g. (K, 1) for one reading), refines the
    proposal with the landmark ``landmarks[k, m]`` (x, y, packed covariance xx, xy, yy).
    ``noise_diag`` holds the (range, bearing) variances, broadcasting likewise. Returns
    (mu_s (n, 3), Sigma_s (n, 3, 3), log N(nu; 0, L) (n,)); a particle without observations
    keeps its prior and gets log weight 0.
    """
    terms = _information(mean, landmarks, ranges, bearings, used, offset, noise_diag)
    sigma, shift, log_weight = _combine(cov, *terms)
    point = mean + shift
    point[:, 2] = wrap_angle(point[:, 2])
    return point, sigma, log_weight


# Cofactor C_ij = a[p] a[q] - a[r] a[s] of a row-major 3x3 matrix, in row-major (i, j) order.
_COF_P, _COF_Q = np.array([4, 5, 3, 2, 0, 1, 1, 2, 0]), np.array([8, 6, 7, 7, 8, 6, 5, 3, 4])
_COF_R, _COF_S = np.array([5, 3, 4, 1, 2, 0, 2, 0, 1]), np.array([7, 8, 6, 8, 6, 7, 4, 5, 3])


def _information(point, landmarks, ranges, bearings, used, offset, noise_diag):
    """Sums over each particle's used observations, linearised at ``point`` (n, 3):
    J (n, 3, 3), b (n, 3), nu^T Q^-1 nu and log det Q (n,), and the number of them (n,).

    The per-pair terms are formed on the dense (K, n) layout and summed over the observations
    by ``einsum``; unused pairs are given a harmless landmark 1 m ahead and contribute zero.
    """
    landmark_x = np.where(used, landmarks[..., 0], point[:, 0] + 1.0)
    landmark_y = np.where(used, landmarks[..., 1], point[:, 1])
    t = observation_terms(point[:, 0], point[:, 1], point[:, 2], landmark_x, landmark_y, offset)
    (g00, g01, g10, g11), _, (q00, q01, q11) = innovation_covariance(
        t, landmarks[..., 2], landmarks[..., 3], landmarks[..., 4], noise_diag)
    # G_s (2, 3, K, n): range row (-g00, -g01, w0), bearing row (-g10, -g11, w1).
    g_s = np.empty((2, 3) + g00.shape)
    np.negative(g00, out=g_s[0, 0])
    np.negative(g01, out=g_s[0, 1])
    np.negative(g10, out=g_s[1, 0])
    np.negative(g11, out=g_s[1, 1])
    g_s[0, 2], g_s[1, 2] = heading_column(t)
    nu = np.empty((2,) + g00.shape)
    np.subtract(ranges, t.range, out=nu[0])
    nu[1] = t.bearing_innovation(bearings)
    det = q00 * q11 - q01 * q01
    q_inv = np.array([[q11, -q01], [-q01, q00]])                       # Q^-1 (2, 2, K, n)
    q_inv *= used / det                                                # 0 where unused
    u = np.einsum("ijkn,jlkn->ilkn", q_inv, g_s)                       # Q^-1 G_s (2, 3, K, n)
    # Summed over the observations k: J = G_s^T Q^-1 G_s, b = G_s^T Q^-1 nu, nu^T Q^-1 nu.
    info = np.einsum("jikn,jlkn->nil", g_s, u)                         # (n, 3, 3)
    b = np.einsum("jikn,jkn->ni", u, nu)                               # (n, 3)
    quadratic = np.einsum("ikn,ijkn,jkn->n", nu, q_inv, nu)
    log_det = np.log(det)
    log_det *= used                                  # unused pairs: a finite det, times 0
    return info, b, quadratic, log_det.sum(axis=0), used.sum(axis=0)


def _combine(cov, info, b, quadratic, log_det_q, pairs):
    """Sigma_s = (I + P J)^-1 P, the mean shift Sigma_s b and the joint log likelihood of the
    innovations.

    The 3x3 inverse is the adjugate over the determinant, all cofactors in one expression.
    """
    a = (cov @ info).reshape(-1, 9).T                                 # rows of I + P J
    a[::4] += 1.0                                                     # rows 0, 4, 8: diagonal
    cofactor = a[_COF_P] * a[_COF_Q] - a[_COF_R] * a[_COF_S]           # (9, n)
    det = (a[:3] * cofactor[:3]).sum(axis=0)
    inverse = (cofactor.reshape(3, 3, -1).transpose(2, 1, 0)) / det[:, None, None]
    sigma = inverse @ cov
    sigma = 0.5 * (sigma + sigma.transpose(0, 2, 1))
    shift = (sigma @ b[:, :, None])[:, :, 0]
    mahalanobis = quadratic - (b * shift).sum(axis=1)
    log_weight = -0.5 * (mahalanobis + log_det_q + np.log(det)) - pairs * LOG_TWO_PI
    return sigma, shift, log_weight


def sample_pose(mean: np.ndarray, cov: np.ndarray, standard_normals: np.ndarray) -> np.ndarray:
    """Draw s ~ N(mean, cov) for every particle from (n, 3) standard normals.

    Cholesky factor written out for 3x3; clipping at the jitter keeps it defined when round-off
    leaves a pivot at or slightly below zero.
    """
    c00, c01, c02 = cov[:, 0, 0], cov[:, 0, 1], cov[:, 0, 2]
    c11, c12, c22 = cov[:, 1, 1], cov[:, 1, 2], cov[:, 2, 2]
    l00 = np.sqrt(np.maximum(c00, 0.0) + POSE_JITTER)
    l10, l20 = c01 / l00, c02 / l00
    l11 = np.sqrt(np.maximum(c11 - l10 * l10, 0.0) + POSE_JITTER)
    l21 = (c12 - l20 * l10) / l11
    l22 = np.sqrt(np.maximum(c22 - l20 * l20 - l21 * l21, 0.0) + POSE_JITTER)
    n0, n1, n2 = standard_normals[:, 0], standard_normals[:, 1], standard_normals[:, 2]
    return mean + np.array([l00 * n0, l10 * n0 + l11 * n1, l20 * n0 + l21 * n1 + l22 * n2]).T
