# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Per-particle data association: maximum likelihood, Monte Carlo, two gates (and scoring).

Every rule sees the same inputs for all rows at once (a row is one observation of one particle):
the log-likelihood and squared Mahalanobis distance against each candidate landmark ((n, C)
arrays, -inf / +inf where there is no candidate), and returns the chosen candidate per row
(``NEW`` or ``IGNORE`` when none) with the log factor that multiplies the particle's weight.
Known ids reuse the maximum-likelihood rule with the id's landmark as the only candidate.
"""
from __future__ import annotations

import numpy as np

from .geometry import LOG_TWO_PI
from .landmark_ekf import innovation_covariance
from .observation import heading_column

NEW = -1
"""The observation starts a new landmark."""
IGNORE = -2
"""The observation is not used: ambiguous (two_gate) or an outlier (``reject_outliers``)."""



def gaussian_log_likelihood(innovation_range, innovation_bearing, cov_xx, cov_xy, cov_yy):
    """log N(nu; 0, S) and nu^T S^-1 nu for 2-D innovations with packed covariance S.

    S usually has fewer entries than the innovations (one per (particle, landmark) pair against
    every observation), so its inverse and log-determinant are formed first, at its own size;
    the broadcast part runs in place (fresh large temporaries cost more than the arithmetic).
    """
    det = cov_xx * cov_yy - cov_xy * cov_xy
    inv_xx, inv_xy2, inv_yy = cov_yy / det, -2.0 * cov_xy / det, cov_xx / det
    mahalanobis = innovation_range * inv_xx
    mahalanobis += inv_xy2 * innovation_bearing
    mahalanobis *= innovation_range
    bearing_term = innovation_bearing * inv_yy
    bearing_term *= innovation_bearing
    mahalanobis += bearing_term
    log_lik = mahalanobis * -0.5
    log_lik -= LOG_TWO_PI + 0.5 * np.log(det)
    return log_lik, mahalanobis


def associate_maximum_likelihood(candidate_log_lik: np.ndarray, log_p0: float):
    """argmax of the likelihoods; a new landmark (weight p0) when all are below p0."""
    if candidate_log_lik.shape[1] == 0:
        count = candidate_log_lik.shape[0]
        return np.full(count, NEW), np.full(count, log_p0)
    best = candidate_log_lik.argmax(axis=1)
    best_log_lik = np.take_along_axis(candidate_log_lik, best[:, None], 1)[:, 0]
    is_new = best_log_lik < log_p0
    return np.where(is_new, NEW, best), np.where(is_new, log_p0, best_log_lik)


def associate_exclusive_maximum_likelihood(candidate_log_lik: np.ndarray, num_particles: int,
                                           log_p0: float):
    """Maximum likelihood where a landmark takes at most one observation of a reading.

    Rows are (observation, particle) pairs, observation-major, and column j is the particle's
    landmark j. In rounds, every observation picks its most likely remaining landmark (or new,
    below p0); when several observations of one particle pick the same landmark, the most
    likely keeps it (ties: the earlier observation) and the others drop it and pick again. A
    point landmark gives at most one detection per reading, so this keeps two nearby
    landmarks from collapsing into one.
    """
    log_lik = candidate_log_lik
    particle = np.arange(len(log_lik)) % num_particles
    while True:
        pick, log_factor = associate_maximum_likelihood(log_lik, log_p0)
        rows = (pick >= 0).nonzero()[0]
        key = particle[rows] * log_lik.shape[1] + pick[rows]
        if len(key) == 0 or np.bincount(key).max() == 1:
            return pick, log_factor
        # Stable sort: among equal likelihoods the earlier observation comes first.
        order = np.lexsort((-log_factor[rows], key))
        sorted_key = key[order]
        losers = rows[order[1:][sorted_key[1:] == sorted_key[:-1]]]
        if log_lik is candidate_log_lik:
            log_lik = log_lik.copy()
        log_lik[losers, pick[losers]] = -np.inf


def associate_monte_carlo(candidate_log_lik: np.ndarray, log_p0: float,
                          rng: np.random.Generator):
    """Sample the association in proportion to the likelihoods (p0 for a new landmark).

    Options are laid out most likely first (then "new"), so the draw does not depend on how
    the map happens to be stored. The log factor is the importance weight of the draw, the sum
    of the likelihoods and p0 (the marginal over associations).
    """
    count, width = candidate_log_lik.shape
    order = np.argsort(-candidate_log_lik, axis=1, kind="stable")
    ordered = np.take_along_axis(candidate_log_lik, order, axis=1)
    log_options = np.concatenate([ordered, np.full((count, 1), log_p0)], axis=1)
    peak = log_options.max(axis=1, keepdims=True)
    cumulative = np.cumsum(np.exp(log_options - peak), axis=1)
    draw = rng.random(count) * cumulative[:, -1]
    picked = np.minimum((cumulative <= draw[:, None]).sum(axis=1), width)
    log_marginal = peak[:, 0] + np.log(cumulative[:, -1])
    chosen = np.take_along_axis(order, np.minimum(picked, max(width - 1, 0))[:, None], 1)[:, 0] \
        if width else picked
    return np.where(picked == width, NEW, chosen), log_marginal


def associate_two_gates(candidate_log_lik: np.ndarray, candidate_mahalanobis: np.ndarray,
                        log_p0: float, association_gate: float, new_landmark_gate: float):
    """Nearest (Mahalanobis) landmark inside the inner gate; new beyond the outer gate."""
    count = candidate_log_lik.shape[0]
    if candidate_mahalanobis.shape[1] == 0:
        return np.full(count, NEW), np.full(count, log_p0)
    nearest = np.argmin(candidate_mahalanobis, axis=1)
    distance = np.take_along_axis(candidate_mahalanobis, nearest[:, None], 1)[:, 0]
    log_lik = np.take_along_axis(candidate_log_lik, nearest[:, None], 1)[:, 0]
    choice = np.where(distance < association_gate, nearest,
                      np.where(distance > new_landmark_gate, NEW, IGNORE))
    factor = np.where(choice >= 0, log_lik, np.where(choice == NEW, log_p0, 0.0))
    return choice, factor


def score(t, landmark_cov: np.ndarray, z_range, z_bearing, noise_diag: np.ndarray,
          pose_cov: np.ndarray | None = None):
    """log N(z; z_hat, S) and the squared Mahalanobis distance for broadcast pairs.

    ``t`` holds the observation terms of the pairs, ``landmark_cov`` their packed covariances
    (..., 3). S = Q = G_m Sigma G_m^T + R (FastSLAM 1.0) or, with the pose covariance P
    (..., 3, 3) broadcasting like the pairs, S = L = G_s P G_s^T + Q (FastSLAM 2.0). The
    position columns of G_s are -G_m, so with P = [[P_xy, c], [c^T, p_tt]] and w the heading
    column of G_s, L = G_m (Sigma + P_xy) G_m^T - G_m c w^T - w c^T G_m^T + p_tt w w^T + R.
    """
    nu_r = z_range - t.range
    nu_b = t.bearing_innovation(z_bearing)
    sxx, sxy, syy = landmark_cov[..., 0], landmark_cov[..., 1], landmark_cov[..., 2]
    if pose_cov is not None:
        sxx, sxy, syy = (sxx + pose_cov[..., 0, 0], sxy + pose_cov[..., 0, 1],
                         syy + pose_cov[..., 1, 1])
    (g00, g01, g10, g11), _, (cxx, cxy, cyy) = innovation_covariance(t, sxx, sxy, syy,
                                                                      noise_diag)
    if pose_cov is not None:
        w0, w1 = heading_column(t)
        c0, c1, p_tt = pose_cov[..., 0, 2], pose_cov[..., 1, 2], pose_cov[..., 2, 2]
        e0, e1 = g00 * c0 + g01 * c1, g10 * c0 + g11 * c1         # G_m c
        if isinstance(w0, float) and w0 == 0.0 and w1 == -1.0:
            # No lever arm: the same terms with w = (0, -1), written out.
            cxy = cxy + e0
            cyy = cyy + p_tt + 2.0 * e1
        else:
            cxx = cxx + (p_tt * w0 - 2.0 * e0) * w0
            cxy = cxy + p_tt * w0 * w1 - e0 * w1 - e1 * w0
            cyy = cyy + (p_tt * w1 - 2.0 * e1) * w1
    return gaussian_log_likelihood(nu_r, nu_b, cxx, cxy, cyy)


def log_outlier_density(config) -> float:
    """log of eps * u, u = 1 / ((max_range - min_range) * field_of_view): the outlier term of
    the robust likelihood (-inf when ``outlier_probability`` is 0)."""
    eps = config.outlier_probability
    if eps <= 0.0:
        return -np.inf
    return float(np.log(eps) - np.log((config.max_range - config.min_range)
                                      * config.field_of_view))


def reject_outliers(choices: np.ndarray, log_lik: np.ndarray, eps: float, log_outlier: float):
    """The robust likelihood (1 - eps) N(z; z_hat, S) + eps u of associated observations.

    ``choices`` and ``log_lik`` (K, M) come from association (log N of the chosen landmark).
    An observation whose outlier term is the larger, (1 - eps) N < eps u, is an outlier: it
    becomes ``IGNORE`` (neither proposal nor landmark update) with weight factor
    log((1 - eps) N + eps u). An inlier keeps its choice; its factor log N is returned as is,
    with ``correction`` = log((1 - eps) N + eps u) - log N to add to whatever Gaussian weight
    the filter computes for it (FastSLAM 2.0 computes one joint weight for all of a reading's
    inliers). Returns (choices, log factors, correction); eps = 0 changes nothing.
    """
    if eps <= 0.0:
        return choices, log_lik, np.zeros_like(log_lik)
    associated = choices >= 0
    inlier_term = np.log1p(-eps) + log_lik
    robust = np.logaddexp(inlier_term, log_outlier)
    outliers = associated & (inlier_term < log_outlier)
    inliers = associated & ~outliers
    return (np.where(outliers, IGNORE, choices), np.where(outliers, robust, log_lik),
            np.where(inliers, robust - np.where(inliers, log_lik, 0.0), 0.0))


def association_score(labels: np.ndarray, is_new: np.ndarray, associated_labels: np.ndarray,
                      labels_mapped_before: np.ndarray) -> tuple[int, int]:
    """(checked, correct): data association of one reading scored against its labels.

    ``labels`` (K,) are the observations' true ids (-1: unlabelled), ``is_new`` and
    ``associated_labels`` what the filter did (the label of the landmark each observation went
    to, -1 for new or unlabelled), ``labels_mapped_before`` the labels of the best particle's
    landmarks before the reading (any order, -1 for unlabelled ones). An observation associated
    to an existing landmark is correct when the landmark carries its label; one that started a
    new landmark, when its label was not yet mapped.
    """
    labelled = labels >= 0
    associated = labelled & ~is_new & (associated_labels >= 0)
    new = labelled & is_new
    correct_new = int(np.count_nonzero(~np.isin(labels[new], labels_mapped_before)))
    checked = int(np.count_nonzero(associated | new))
    correct = int(np.count_nonzero(associated_labels[associated] == labels[associated]))
    return checked, correct + correct_new
