# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""numba twin of ``core/proposal.py``: the FastSLAM 2.0 proposal of one particle (the
Gaussian over its pose given the associated observations) and the draw from it; constants
imported from the numpy module."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..geometry import LOG_TWO_PI
from ..proposal import _COF_P, _COF_Q, _COF_R, _COF_S, POSE_JITTER
from .jit import _INLINED, _JIT, _lever, _wrap


@njit(**_INLINED)
def _propose_and_draw(m, state, particles, obs, choice, settings, normals, poses_out, work,
                      scored):
    """``proposal.observation_proposal`` (linearised once) from particle m's associated
    observations, then ``sample_pose`` from it into ``poses_out[m]`` (heading wrapped);
    returns the joint log likelihood of those observations. ``scored``: the pairs' terms,
    taken at the same mean, are in ``work.terms[work.picked[k]]`` (the same numbers, not
    recomputed); ``work``'s (``Scratch``) info, b, a, cof, full and sigma are its buffers."""
    ox, oy, oyaw = settings.sensor_x, settings.sensor_y, settings.sensor_yaw
    noise_b = settings.bearing_variance
    mean, cov = particles.mean, particles.cov
    ranges, bearings, noise_r = obs.ranges, obs.bearings, obs.range_variance
    info, b, a, cof, full, sigma = work.info, work.b, work.a, work.cof, work.full, work.sigma
    terms, picked = work.terms, work.picked
    px, py, pth = mean[m, 0], mean[m, 1], mean[m, 2]
    lx, ly = _lever(pth, ox, oy)
    lever_free = lx == 0.0 and ly == 0.0 and ox == 0.0 and oy == 0.0
    for i in range(9):
        info[i] = 0.0
    b[0] = b[1] = b[2] = 0.0
    quadratic = 0.0
    log_det_q = 0.0
    pairs = 0
    for k in range(choice.shape[0]):
        j = choice[k, m]
        if j < 0:
            continue
        pairs += 1
        if scored:
            c = picked[k]
            dx, dy, q, r, bearing = (terms[c, 0], terms[c, 1], terms[c, 2], terms[c, 3],
                                     terms[c, 4])
        else:
            dx = state[m, j, 0] - (px + lx)
            dy = state[m, j, 1] - (py + ly)
            q = dx * dx + dy * dy
            r = math.sqrt(q)
            bearing = math.atan2(dy, dx)
        sxx, sxy, syy = state[m, j, 2], state[m, j, 3], state[m, j, 4]
        g00, g01 = dx / r, dy / r
        g10, g11 = -dy / q, dx / q
        a0, a1 = sxx * g00 + sxy * g01, sxy * g00 + syy * g01
        b0, b1 = sxx * g10 + sxy * g11, sxy * g10 + syy * g11
        q00 = g00 * a0 + g01 * a1 + noise_r[k]
        q01 = g10 * a0 + g11 * a1
        q11 = g10 * b0 + g11 * b1 + noise_b
        if lever_free:
            w0, w1 = 0.0, -1.0
        else:
            w0 = (dx * ly - dy * lx) / r
            w1 = -(dx * lx + dy * ly) / q - 1.0
        # Rows of G_s: (-g00, -g01, w0) and (-g10, -g11, w1).
        h00, h01, h02 = -g00, -g01, w0
        h10, h11, h12 = -g10, -g11, w1
        nu0 = ranges[k] - r
        nu1 = _wrap(bearings[k] + (pth + oyaw) - bearing)
        det = q00 * q11 - q01 * q01
        scale = 1.0 / det
        i00, i01, i11 = q11 * scale, -q01 * scale, q00 * scale
        u00, u01, u02 = i00 * h00 + i01 * h10, i00 * h01 + i01 * h11, i00 * h02 + i01 * h12
        u10, u11, u12 = i01 * h00 + i11 * h10, i01 * h01 + i11 * h11, i01 * h02 + i11 * h12
        info[0] += h00 * u00 + h10 * u10
        info[1] += h00 * u01 + h10 * u11
        info[2] += h00 * u02 + h10 * u12
        info[3] += h01 * u00 + h11 * u10
        info[4] += h01 * u01 + h11 * u11
        info[5] += h01 * u02 + h11 * u12
        info[6] += h02 * u00 + h12 * u10
        info[7] += h02 * u01 + h12 * u11
        info[8] += h02 * u02 + h12 * u12
        b[0] += u00 * nu0 + u10 * nu1
        b[1] += u01 * nu0 + u11 * nu1
        b[2] += u02 * nu0 + u12 * nu1
        quadratic += nu0 * (i00 * nu0 + i01 * nu1) + nu1 * (i01 * nu0 + i11 * nu1)
        log_det_q += math.log(det)
    # Sigma_s = (I + P J)^-1 P through the adjugate (``proposal._combine``).
    for row in range(3):
        for col in range(3):
            a[3 * row + col] = (cov[m, row, 0] * info[col] + cov[m, row, 1] * info[3 + col]
                                + cov[m, row, 2] * info[6 + col])
    a[0] += 1.0
    a[4] += 1.0
    a[8] += 1.0
    for i in range(9):
        cof[i] = a[_COF_P[i]] * a[_COF_Q[i]] - a[_COF_R[i]] * a[_COF_S[i]]
    det_a = a[0] * cof[0] + a[1] * cof[1] + a[2] * cof[2]
    for row in range(3):
        for col in range(3):
            full[3 * row + col] = (cof[row] * cov[m, 0, col] + cof[3 + row] * cov[m, 1, col]
                                   + cof[6 + row] * cov[m, 2, col]) / det_a
    for row in range(3):
        for col in range(3):
            sigma[3 * row + col] = 0.5 * (full[3 * row + col] + full[3 * col + row])
    mahalanobis = quadratic
    for row in range(3):
        shift = sigma[3 * row] * b[0] + sigma[3 * row + 1] * b[1] + sigma[3 * row + 2] * b[2]
        mahalanobis -= b[row] * shift
        full[row] = mean[m, row] + shift
    full[2] = _wrap(full[2])
    joint = -0.5 * (mahalanobis + log_det_q + math.log(det_a)) - pairs * LOG_TWO_PI
    _draw_pose(full[0], full[1], full[2], sigma[0], sigma[1], sigma[2], sigma[4], sigma[5],
               sigma[8], normals, m, poses_out)
    poses_out[m, 2] = _wrap(poses_out[m, 2])
    return joint


@njit(**_JIT)
def _draw_pose(mx, my, mt, c00, c01, c02, c11, c12, c22, normals, m, out):
    """``proposal.sample_pose`` of one particle into ``out[m]`` (heading not wrapped)."""
    l00 = math.sqrt(max(c00, 0.0) + POSE_JITTER)
    l10, l20 = c01 / l00, c02 / l00
    l11 = math.sqrt(max(c11 - l10 * l10, 0.0) + POSE_JITTER)
    l21 = (c12 - l20 * l10) / l11
    l22 = math.sqrt(max(c22 - l20 * l20 - l21 * l21, 0.0) + POSE_JITTER)
    n0, n1, n2 = normals[m, 0], normals[m, 1], normals[m, 2]
    out[m, 0] = mx + l00 * n0
    out[m, 1] = my + (l10 * n0 + l11 * n1)
    out[m, 2] = mt + (l20 * n0 + l21 * n1 + l22 * n2)


@njit(**_JIT)
def _sample_pose_kernel(mean, cov, normals):
    count = mean.shape[0]
    out = np.empty((count, 3))
    for m in range(count):
        _draw_pose(mean[m, 0], mean[m, 1], mean[m, 2], cov[m, 0, 0], cov[m, 0, 1],
                   cov[m, 0, 2], cov[m, 1, 1], cov[m, 1, 2], cov[m, 2, 2], normals, m, out)
    return out


def sample_pose(mean: np.ndarray, cov: np.ndarray, standard_normals: np.ndarray) -> np.ndarray:
    """``proposal.sample_pose``."""
    return _sample_pose_kernel(np.ascontiguousarray(mean), np.ascontiguousarray(cov),
                               np.ascontiguousarray(standard_normals))
