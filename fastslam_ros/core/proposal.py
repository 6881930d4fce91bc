"""FastSLAM 2.0: the pose proposal that uses the current observation, and its weight.

With the motion model linearised as s_t ~ N(s_hat, P) and the observation linearised in the pose
(G_s) and the landmark (G_m), the textbook proposal is

    Sigma_s = (G_s^T Q^-1 G_s + P^-1)^-1
    mu_s    = Sigma_s G_s^T Q^-1 (z - z_hat) + s_hat,     Q = G_m Sigma_m G_m^T + R,

and the importance weight is N(z; z_hat, L) with L = G_s P G_s^T + Q. By the matrix inversion
lemma this is a Kalman update of the pose with gain K = P G_s^T L^-1:

    mu_s = s_hat + K (z - z_hat),    Sigma_s = P - K L K^T,

which needs no inverse of P (P is singular when the robot does not translate). Several
observations in one step apply this update one after another, each starting from the previous
(mu_s, Sigma_s), and their weights multiply. ``information_form_proposal`` is the textbook form,
kept for the tests that prove the two agree.

All functions work on every particle at once (leading dimension n) and spell the 2x3 / 3x3
products out component by component: numpy's stacked matmul and inv cost ~100x more per tiny
matrix than a few elementwise operations.
"""
from __future__ import annotations

import numpy as np

POSE_JITTER = 1e-12
"""Variance added to the proposal diagonal before factorising it (sigma 1e-6 m, rad)."""


def refine_proposal(mean: np.ndarray, cov: np.ndarray, pose_jacobian: np.ndarray,
                    innovation: np.ndarray, landmark_term: np.ndarray):
    """One observation's update of the pose proposal for n particles.

    mean (n, 3), cov (n, 3, 3), pose_jacobian G_s (n, 2, 3), innovation z - z_hat (n, 2) with
    the bearing wrapped, landmark_term Q = G_m Sigma_m G_m^T + R packed as (xx, xy, yy) (n, 3).
    Returns (mean, cov, log N(innovation; 0, L)) with L = G_s P G_s^T + Q.
    """
    g, h = pose_jacobian[:, 0, :], pose_jacobian[:, 1, :]
    p_g = np.einsum("nij,nj->ni", cov, g)                      # P g   (n, 3)
    p_h = np.einsum("nij,nj->ni", cov, h)                      # P h   (n, 3)
    l00 = np.einsum("ni,ni->n", g, p_g) + landmark_term[:, 0]
    l01 = np.einsum("ni,ni->n", g, p_h) + landmark_term[:, 1]
    l11 = np.einsum("ni,ni->n", h, p_h) + landmark_term[:, 2]
    det = l00 * l11 - l01 * l01
    i00, i01, i11 = l11 / det, -l01 / det, l00 / det            # L^-1
    gain0 = p_g * i00[:, None] + p_h * i01[:, None]             # K[:, :, 0]
    gain1 = p_g * i01[:, None] + p_h * i11[:, None]             # K[:, :, 1]
    nu0, nu1 = innovation[:, 0], innovation[:, 1]
    new_mean = mean + gain0 * nu0[:, None] + gain1 * nu1[:, None]
    # P - K L K^T = P - [Pg Ph] L^-1 [Pg Ph]^T, symmetric by construction.
    new_cov = cov - (p_g[:, :, None] * gain0[:, None, :] + p_h[:, :, None] * gain1[:, None, :])
    mahalanobis = i00 * nu0 * nu0 + 2.0 * i01 * nu0 * nu1 + i11 * nu1 * nu1
    log_weight = -0.5 * mahalanobis - np.log(2.0 * np.pi) - 0.5 * np.log(det)
    return new_mean, new_cov, log_weight


def information_form_proposal(mean: np.ndarray, cov: np.ndarray, pose_jacobian: np.ndarray,
                              innovation: np.ndarray, landmark_term: np.ndarray):
    """The textbook (information) form of the same proposal, for invertible P (tests, docs)."""
    q_inv = np.linalg.inv(landmark_term)
    gt_q_inv = pose_jacobian.transpose(0, 2, 1) @ q_inv
    sigma = np.linalg.inv(gt_q_inv @ pose_jacobian + np.linalg.inv(cov))
    new_mean = mean + (sigma @ gt_q_inv @ innovation[:, :, None])[:, :, 0]
    return new_mean, sigma


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
    return mean + np.stack([l00 * n0, l10 * n0 + l11 * n1, l20 * n0 + l21 * n1 + l22 * n2], -1)
