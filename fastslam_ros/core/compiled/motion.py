# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""numba twin of ``core/motion.py``: odometry sampling and the moved prior of FastSLAM 2.0
(its mean and the propagated covariance)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .jit import _JIT, _wrap
from .settings import ReadingSettings


_NO_COV = np.zeros((1, 3, 3))


@njit(**_JIT)
def _sample_motion_kernel(poses, rot1, trans, rot2, sigma_rot1, sigma_trans, sigma_rot2,
                          normals):
    count = poses.shape[0]
    moved = np.empty((count, 3))
    for m in range(count):
        noisy_rot1 = rot1 - normals[m, 0] * sigma_rot1
        noisy_trans = trans - normals[m, 1] * sigma_trans
        noisy_rot2 = rot2 - normals[m, 2] * sigma_rot2
        heading = poses[m, 2] + noisy_rot1
        moved[m, 0] = poses[m, 0] + noisy_trans * math.cos(heading)
        moved[m, 1] = poses[m, 1] + noisy_trans * math.sin(heading)
        moved[m, 2] = _wrap(heading + noisy_rot2)
    return moved


def sample_motion(poses: np.ndarray, u, variances: np.ndarray,
                  standard_normals: np.ndarray) -> np.ndarray:
    """``motion.sample_motion``."""
    sigma_rot1, sigma_trans, sigma_rot2 = (float(v) for v in np.sqrt(variances))
    return _sample_motion_kernel(np.ascontiguousarray(poses), float(u.rot1), float(u.trans),
                                 float(u.rot2), sigma_rot1, sigma_trans, sigma_rot2,
                                 np.ascontiguousarray(standard_normals))


@njit(**_JIT)
def _propagate_mean(m, mean, rot1, trans, rot2, moved, turn):
    """``propagate_gaussian``'s mean of particle m into ``moved[m]``, the cosine and sine of
    its heading after the first rotation into ``turn[m]`` (for ``_propagate_cov``)."""
    heading = mean[m, 2] + rot1
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    moved[m, 0] = mean[m, 0] + trans * cos_h
    moved[m, 1] = mean[m, 1] + trans * sin_h
    moved[m, 2] = _wrap(heading + rot2)
    turn[m, 0], turn[m, 1] = cos_h, sin_h


@njit(**_JIT)
def _propagate_cov(m, turn, cov, has_cov, trans, v_rot1, v_trans, v_rot2, predicted):
    """``propagate_gaussian``'s covariance of particle m (covariance ``cov[m]``, or zero
    without ``has_cov``; ``turn[m]``: ``_propagate_mean``'s) into ``predicted[m]``."""
    cos_h, sin_h = turn[m, 0], turn[m, 1]
    fx, fy = -trans * sin_h, trans * cos_h
    n = m if has_cov else 0
    c0, c1, c2 = cov[n, 0, 2], cov[n, 1, 2], cov[n, 2, 2]
    w = c2 + v_rot1
    xx = cov[n, 0, 0] + 2.0 * fx * c0 + w * fx * fx + v_trans * cos_h * cos_h
    xy = cov[n, 0, 1] + fx * c1 + fy * c0 + w * fx * fy + v_trans * cos_h * sin_h
    yy = cov[n, 1, 1] + 2.0 * fy * c1 + w * fy * fy + v_trans * sin_h * sin_h
    xt, yt, tt = c0 + w * fx, c1 + w * fy, c2 + (v_rot1 + v_rot2)
    predicted[m, 0, 0], predicted[m, 0, 1], predicted[m, 0, 2] = xx, xy, xt
    predicted[m, 1, 0], predicted[m, 1, 1], predicted[m, 1, 2] = xy, yy, yt
    predicted[m, 2, 0], predicted[m, 2, 1], predicted[m, 2, 2] = xt, yt, tt


@njit(**_JIT)
def _motion_of(dx, dy, dtheta, settings):
    """The odometry delta's (rot1, trans, rot2) (``OdometryControl.from_delta``) and their
    variances (``motion.control_variances``)."""
    trans = math.hypot(dx, dy)
    rot1 = math.atan2(dy, dx) if trans > 1e-9 else 0.0
    if abs(rot1) > math.pi / 2.0:
        rot1 = _wrap(rot1 - math.pi)
        trans = -trans
    rot2 = _wrap(dtheta - rot1)
    a1, a2, a3, a4 = settings.alpha1, settings.alpha2, settings.alpha3, settings.alpha4
    min_t, min_r = settings.min_translation_sigma, settings.min_rotation_sigma
    rot1_sq, trans_sq, rot2_sq = rot1 ** 2, trans ** 2, rot2 ** 2
    v_rot1 = a1 * rot1_sq + a2 * trans_sq + min_r ** 2
    v_trans = a3 * trans_sq + a4 * (rot1_sq + rot2_sq) + min_t ** 2
    v_rot2 = a1 * rot2_sq + a2 * trans_sq + min_r ** 2
    k_rr, k_rt = settings.rotation_variance_per_radian, settings.rotation_variance_per_meter
    k_tt = settings.translation_variance_per_meter
    k_tr = settings.translation_variance_per_radian
    if k_rr != 0.0 or k_rt != 0.0 or k_tt != 0.0 or k_tr != 0.0:
        v_rot1 += k_rr * abs(rot1) + 0.5 * k_rt * abs(trans)
        v_trans += k_tt * abs(trans) + k_tr * (abs(rot1) + abs(rot2))
        v_rot2 += k_rr * abs(rot2) + 0.5 * k_rt * abs(trans)
    return rot1, trans, rot2, v_rot1, v_trans, v_rot2


@njit(**_JIT)
def _widest_kernel(cov, has_cov, count, v_rot1, v_rot2):
    """The largest propagated heading variance (``_propagate_cov``'s ``tt``); as numpy's max,
    a NaN makes it NaN (numba's max would skip it)."""
    widest = -np.inf
    for m in range(count):
        variance = cov[m if has_cov else 0, 2, 2] + (v_rot1 + v_rot2)
        if np.isnan(variance) or variance > widest:
            widest = variance
    return widest


@njit(**_JIT)
def _advance_mean_kernel(mean, cov, has_cov, dx, dy, dtheta, settings):
    settings = ReadingSettings(*settings)  # a plain tuple from Python (``records``)
    motion = np.array(_motion_of(dx, dy, dtheta, settings))
    count = mean.shape[0]
    moved = np.empty((count, 3))
    turn = np.empty((count, 2))
    for m in range(count):
        _propagate_mean(m, mean, motion[0], motion[1], motion[2], moved, turn)
    return moved, _widest_kernel(cov, has_cov, count, motion[3], motion[5]), turn, motion


@njit(**_JIT)
def _propagate_cov_kernel(turn, cov, has_cov, motion):
    count = turn.shape[0]
    predicted = np.empty((count, 3, 3))
    for m in range(count):
        _propagate_cov(m, turn, cov, has_cov, motion[1], motion[3], motion[4], motion[5],
                       predicted)
    return predicted


def advance_mean(prior, poses: np.ndarray, delta, settings: ReadingSettings):
    """FastSLAM 2.0's ``_advance_motion`` but for the covariance: the odometry ``delta`` (dx,
    dy, dtheta) decomposed (``OdometryControl.from_delta``), its variances
    (``control_variances``) and the prior's mean (of (mean, cov), or of N(poses, 0) when
    ``prior`` is None) propagated through it (``propagate_gaussian``). Returns the new mean,
    the largest new heading variance, the cosine and sine of every heading after the first
    rotation (M, 2) and the motion (rot1, trans, rot2 and their variances), for
    ``propagate_cov`` or ``update_reading``'s ``motion``, which propagate the covariance: the
    next reading does it in its blocks of particles."""
    mean, cov = prior if prior is not None else (poses, _NO_COV)
    return _advance_mean_kernel(mean, cov, prior is not None, *delta,
                                tuple(settings))


def propagate_cov(turn: np.ndarray, cov: np.ndarray | None, motion: np.ndarray) -> np.ndarray:
    """``propagate_gaussian``'s covariance of the prior (cov None: zero) through the motion
    and turn of ``advance_mean``."""
    return _propagate_cov_kernel(turn, _NO_COV if cov is None else cov, cov is not None,
                                 motion)
