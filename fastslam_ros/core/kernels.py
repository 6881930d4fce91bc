# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Compiled (numba) backend of the per-reading math of ``FastSLAM``.

The numpy core spends most of a reading at moderate M on call overhead (hundreds of small array
operations whatever M is). Here one compiled call, ``update_reading``, does the whole reading
for every particle: candidates in reach, scoring and the four association rules, the outlier
test, the FastSLAM 2.0 proposal and its draw, the weight update, the columns and keys of new
landmarks, their initialisation and the Joseph-form updates, negative evidence, the weight
normalisation, N_eff and the reported particle. The results are those of the numpy reference
(``FastSLAM._associate``, ``proposal``, ``FastSLAM._apply_to_map``, ``_missed_evidence``,
``resampling``): the same discrete choices and floats equal to round-off, on the same random
draws (drawn by the caller from its ``numpy.random.Generator`` in the numpy path's order).

The per-particle work is one loop over particles (``_reading_chunk``: each particle's
association, proposal, weight and map in turn), then a short serial pass (``_settle``: the
columns and keys of the new landmarks, which need every particle's choices, the weight
normalisation and the report). Below ``PARALLEL_MIN_PARTICLES`` (or with one thread) the reading
runs on the calling thread; from there on the loop runs on the calling thread and on worker
threads kept across readings (``_Crew``) at once, in the same compiled serial code (the
kernels release the GIL), one hand-off per reading, each thread taking blocks of particles
from one atomic counter until none is left (so a thread that starts late or runs slower takes
fewer) and counting the particles it finished in another, which the calling thread waits for
in compiled code. A hand-off costs tens of microseconds on a busy machine, which only pays off
at large M. (numba's own
``prange`` compiled the chunks' code for generic array layouts, about 25 % slower per
particle, and gained little from the second core.)

numba is optional (``pip install fastslam_ros[fast]``); importing this module without it raises
ImportError, and the filter then runs on numpy. ``warm_up`` compiles the kernels (or loads them
from numba's cache) so that compilation never lands on the first reading. The cache lives beside
this file when its folder is writable and in numba's user cache folder otherwise
(``NUMBA_CACHE_DIR`` overrides both), so a read-only install works.
"""
from __future__ import annotations

import math
import queue
import threading
import time
from typing import NamedTuple

import numpy as np
import numba
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from .existence import EXPLAINED_GATE
from .geometry import LOG_TWO_PI, TWO_PI
from .landmark_store import STATE_WIDTH, LandmarkStore, WorkingSet

POSE_JITTER = 1e-12
LOG2 = math.log(2.0)

MODE_CODES = {"known": 0, "ml": 1, "monte_carlo": 2, "two_gate": 3}
NEW, IGNORE = -1, -2

_JIT = dict(cache=True, nogil=True, error_model="numpy")

# Cofactor C_ij = a[p] a[q] - a[r] a[s] of a row-major 3x3 matrix (as in ``proposal``).
_COF_P = np.array([4, 5, 3, 2, 0, 1, 1, 2, 0])
_COF_Q = np.array([8, 6, 7, 7, 8, 6, 5, 3, 4])
_COF_R = np.array([5, 3, 4, 1, 2, 0, 2, 0, 1])
_COF_S = np.array([7, 8, 6, 8, 6, 7, 4, 5, 3])

# Layout of the settings of a reading: floats ``fp`` and integers ``ip`` (``ReadingSettings``).
F_OX, F_OY, F_OYAW, F_NOISE_R, F_NOISE_R_PER_M, F_NOISE_B = 0, 1, 2, 3, 4, 5
F_LOG_P0, F_GATE, F_NEW_GATE, F_EPS, F_LOG_OUTLIER = 6, 7, 8, 9, 10
F_MIN_RANGE, F_MAX_RANGE, F_FOV = 11, 12, 13
F_LOGODDS_OBSERVED, F_LOGODDS_MISSED, F_LOGODDS_REMOVE, F_LOGODDS_MAX = 14, 15, 16, 17
F_REACH = 18
F_ALPHAS = 19                                  # alpha1..alpha4
F_MIN_TRANSLATION_SIGMA, F_MIN_ROTATION_SIGMA = 23, 24
F_LINEAR_NOISE = 25                            # the four random-walk terms (``motion``)
F_MOTION = 29                                  # rot1, trans, rot2 and their variances
F_CONFIRMED, F_CONFIRMED_MISSED, F_EXPLAINED_GATE = 35, 36, 37   # ``existence``'s rules
NUM_F = 38
I_MODE, I_LOCALIZATION, I_CENTRAL, I_SCORE_KNOWN, I_HAS_COV, I_PROPOSE, I_FIRST_KEY = range(7)
I_MOTION, I_PRIOR_COV = 7, 8                   # the reading propagates the prior's covariance
NUM_I = 9


@njit(**_JIT)
def _wrap(angle):
    """``geometry.wrap_scalar``."""
    return min(angle - TWO_PI * math.ceil(angle * (1.0 / TWO_PI) - 0.5), math.pi)


@njit(**_JIT)
def _lever(theta, ox, oy):
    """Sensor position relative to the robot in the world frame (0 without an offset)."""
    if ox == 0.0 and oy == 0.0:
        return 0.0, 0.0
    c, s = math.cos(theta), math.sin(theta)
    return c * ox - s * oy, s * ox + c * oy


@njit(**_JIT)
def _logaddexp(x, y):
    """``numpy.logaddexp`` of two floats (same branches)."""
    if x == y:
        return x + LOG2
    difference = x - y
    if difference > 0.0:
        return x + math.log1p(math.exp(-difference))
    if difference <= 0.0:
        return y + math.log1p(math.exp(difference))
    return difference


@intrinsic
def _claim(typingctx, counter, index, amount):
    """Atomically ``counter[index] += amount``; returns the value before (the threads of a
    reading take their particles from one counter this way, and count the particles done in
    another; ``amount`` 0 reads it)."""
    if not (isinstance(counter, types.Array) and counter.dtype == types.int64
            and isinstance(index, types.Integer) and isinstance(amount, types.Integer)):
        return None

    def codegen(context, builder, signature, args):
        array_type = signature.args[0]
        array = context.make_array(array_type)(context, builder, args[0])
        position = context.cast(builder, args[1], signature.args[1], types.intp)
        pointer = cgutils.get_item_pointer(context, builder, array_type, array, [position])
        step = context.cast(builder, args[2], signature.args[2], types.int64)
        return builder.atomic_rmw("add", pointer, step, "seq_cst")

    return types.int64(counter, index, amount), codegen


@njit(**_JIT)
def _await_done(counter, total, spins):
    """Wait (at most ``spins`` polls, without the GIL) until ``counter[1]``, the particles
    the threads of a reading have finished, reaches ``total``; True if it did."""
    for _ in range(spins):
        if _claim(counter, 1, 0) >= total:
            return True
    return _claim(counter, 1, 0) >= total


# ---------------------------------------------------------------------------- association
@njit(**_JIT)
def _score_pair(m, j, k_lo, k_hi, state, mean, cov, has_cov, fp, ranges, bearings, noise_r,
                log_lik, mahalanobis, column, terms):
    """log N and Mahalanobis distance of observations [k_lo, k_hi) against landmark j of
    particle m (``association.score``), into column ``column`` of the (K, C) buffers; the
    pair's (dx, dy, q, r, predicted bearing) into ``terms[column]`` (the proposal reuses
    them)."""
    ox, oy, oyaw, noise_b = fp[F_OX], fp[F_OY], fp[F_OYAW], fp[F_NOISE_B]
    px, py, pth = mean[m, 0], mean[m, 1], mean[m, 2]
    lx, ly = _lever(pth, ox, oy)
    dx = state[m, j, 0] - (px + lx)
    dy = state[m, j, 1] - (py + ly)
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    heading = pth + oyaw
    sxx, sxy, syy = state[m, j, 2], state[m, j, 3], state[m, j, 4]
    if has_cov:
        sxx = sxx + cov[m, 0, 0]
        sxy = sxy + cov[m, 0, 1]
        syy = syy + cov[m, 1, 1]
    g00, g01 = dx / r, dy / r
    g10, g11 = -dy / q, dx / q
    a0, a1 = sxx * g00 + sxy * g01, sxy * g00 + syy * g01
    b0, b1 = sxx * g10 + sxy * g11, sxy * g10 + syy * g11
    base00 = g00 * a0 + g01 * a1
    cxy0 = g10 * a0 + g11 * a1
    cyy0 = g10 * b0 + g11 * b1 + noise_b
    extra_xx = extra_xy = extra_yy = 0.0
    lever_free = lx == 0.0 and ly == 0.0 and ox == 0.0 and oy == 0.0
    if has_cov:
        c0, c1, p_tt = cov[m, 0, 2], cov[m, 1, 2], cov[m, 2, 2]
        e0, e1 = g00 * c0 + g01 * c1, g10 * c0 + g11 * c1
        if lever_free:
            extra_xy = e0
            extra_yy = p_tt + 2.0 * e1
        else:
            w0 = (dx * ly - dy * lx) / r
            w1 = -(dx * lx + dy * ly) / q - 1.0
            extra_xx = (p_tt * w0 - 2.0 * e0) * w0
            extra_xy = p_tt * w0 * w1 - e0 * w1 - e1 * w0
            extra_yy = (p_tt * w1 - 2.0 * e1) * w1
    predicted_bearing = math.atan2(dy, dx)
    terms[column, 0], terms[column, 1], terms[column, 2] = dx, dy, q
    terms[column, 3], terms[column, 4] = r, predicted_bearing
    cxy = cxy0 + extra_xy
    cyy = cyy0 + extra_yy
    last_noise = np.nan
    inv_xx = inv_xy2 = inv_yy = log_norm = 0.0
    for k in range(k_lo, k_hi):
        if noise_r[k] != last_noise:
            # S depends on the observation only through its range noise: mostly one S.
            last_noise = noise_r[k]
            cxx = base00 + noise_r[k] + extra_xx
            det = cxx * cyy - cxy * cxy
            inv_xx, inv_xy2, inv_yy = cyy / det, -2.0 * cxy / det, cxx / det
            log_norm = LOG_TWO_PI + 0.5 * math.log(det)
        nu_r = ranges[k] - r
        nu_b = _wrap(bearings[k] + heading - predicted_bearing)
        distance = ((nu_r * inv_xx) + inv_xy2 * nu_b) * nu_r + (nu_b * inv_yy) * nu_b
        mahalanobis[k, column] = distance
        log_lik[k, column] = distance * -0.5 - log_norm


@njit(**_JIT)
def _argmax_first(row, width):
    """numpy's argmax of row[:width]: the first maximum (0 when all are -inf)."""
    best, value = 0, row[0]
    for c in range(1, width):
        if row[c] > value:
            best, value = c, row[c]
    return best, value


@njit(**_JIT)
def _exclusive_ml(log_lik, width, log_p0, choice, factor, m, pick, value):
    """``association.associate_exclusive_maximum_likelihood`` for one particle."""
    count = choice.shape[0]
    while True:
        for k in range(count):
            if width == 0:
                pick[k], value[k] = NEW, log_p0
                continue
            best, best_value = _argmax_first(log_lik[k], width)
            if best_value < log_p0:
                pick[k], value[k] = NEW, log_p0
            else:
                pick[k], value[k] = best, best_value
        conflict = False
        for k in range(count):
            if pick[k] < 0:
                continue
            # The most likely observation of this landmark keeps it (ties: the earliest).
            winner = k
            for other in range(count):
                if other != k and pick[other] == pick[k]:
                    if value[other] > value[winner] or (value[other] == value[winner]
                                                        and other < winner):
                        winner = other
            if winner != k:
                conflict = True
                log_lik[k, pick[k]] = -np.inf
        if not conflict:
            break
    for k in range(count):
        choice[k, m] = pick[k]
        factor[k, m] = value[k]


@njit(**_JIT)
def _monte_carlo(log_lik, width, log_p0, draws, choice, factor, inverse_q, m, order,
                 cumulative):
    """``association.associate_monte_carlo`` (marginal weight) for one particle."""
    count, num_particles = choice.shape
    for k in range(count):
        row = log_lik[k]
        # Stable descending order (insertion sort: C is a few tens).
        for c in range(width):
            order[c] = c
            i = c
            while i > 0 and row[order[i - 1]] < row[c]:
                order[i] = order[i - 1]
                i -= 1
            order[i] = c
        peak = log_p0
        for c in range(width):
            if row[c] > peak:
                peak = row[c]
        total = 0.0
        for c in range(width):
            total += math.exp(row[order[c]] - peak)
            cumulative[c] = total
        total += math.exp(log_p0 - peak)
        cumulative[width] = total
        draw = draws[k * num_particles + m] * total
        picked = 0
        for c in range(width + 1):
            if cumulative[c] <= draw:
                picked += 1
        if picked > width:
            picked = width
        log_marginal = peak + math.log(total)
        factor[k, m] = log_marginal
        if picked == width:
            choice[k, m] = NEW
        else:
            chosen = order[picked]
            choice[k, m] = chosen
            inverse_q[k] = log_marginal - row[chosen]


@njit(**_JIT)
def _two_gates(log_lik, mahalanobis, width, log_p0, gate, new_gate, choice, factor, m):
    """``association.associate_two_gates`` for one particle."""
    for k in range(choice.shape[0]):
        if width == 0:
            choice[k, m], factor[k, m] = NEW, log_p0
            continue
        nearest, distance = 0, mahalanobis[k, 0]
        for c in range(1, width):
            if mahalanobis[k, c] < distance:
                nearest, distance = c, mahalanobis[k, c]
        if distance < gate:
            choice[k, m], factor[k, m] = nearest, log_lik[k, nearest]
        elif distance > new_gate:
            choice[k, m], factor[k, m] = NEW, log_p0
        else:
            choice[k, m], factor[k, m] = IGNORE, 0.0


@njit(**_JIT)
def _associate_particle(m, state, valid, label, existing, mean, cov, ranges, bearings, labels,
                        noise_r, draws, fp, ip, choice, factor, inverse_q, local, log_lik,
                        mahalanobis, pick, value, order, cumulative, terms, picked):
    """``FastSLAM._associate`` for particle m before the outlier test: its choices (working-set
    columns or ``NEW`` / ``IGNORE``) and log factors into column m of ``choice`` and
    ``factor``, log(1 / q) of its associations into ``inverse_q`` (K,); ``picked[k]``: the row
    of ``terms`` of the chosen candidate (but with known ids)."""
    count = ranges.shape[0]
    has_cov = ip[I_HAS_COV] != 0
    log_p0 = fp[F_LOG_P0]
    for k in range(count):
        inverse_q[k] = 0.0
    if ip[I_MODE] == 0:
        for k in range(count):
            candidate = -1
            for j in range(existing):
                if valid[m, j] and label[m, j] == labels[k]:
                    candidate = j
                    break
            choice[k, m] = candidate
            if candidate < 0:
                factor[k, m] = log_p0
            elif ip[I_SCORE_KNOWN] != 0:
                _score_pair(m, candidate, k, k + 1, state, mean, cov, has_cov, fp, ranges,
                            bearings, noise_r, log_lik, mahalanobis, 0, terms)
                factor[k, m] = log_lik[k, 0]
            else:
                factor[k, m] = 0.0
        return
    # This particle's candidates within reach, in column order: the rules see the same
    # choices as on the numpy path's full row, where the others are -inf / +inf.
    limit = fp[F_REACH] * fp[F_REACH]
    found = 0
    for j in range(existing):
        if valid[m, j]:
            dx = state[m, j, 0] - mean[m, 0]
            dy = state[m, j, 1] - mean[m, 1]
            if dx * dx + dy * dy <= limit:
                local[found] = j
                found += 1
    for c in range(found):
        _score_pair(m, local[c], 0, count, state, mean, cov, has_cov, fp, ranges, bearings,
                    noise_r, log_lik, mahalanobis, c, terms)
    mode = ip[I_MODE]
    if mode == 1:
        _exclusive_ml(log_lik, found, log_p0, choice, factor, m, pick, value)
    elif mode == 2:
        _monte_carlo(log_lik, found, log_p0, draws, choice, factor, inverse_q, m, order,
                     cumulative)
    else:
        _two_gates(log_lik, mahalanobis, found, log_p0, fp[F_GATE], fp[F_NEW_GATE], choice,
                   factor, m)
    for k in range(count):
        picked[k] = choice[k, m]
        if choice[k, m] >= 0:
            choice[k, m] = local[choice[k, m]]


@njit(**_JIT)
def _reject_outliers(m, choice, factor, robust, fp):
    """``association.reject_outliers`` for particle m: outliers become ``IGNORE`` with the
    robust factor; ``robust`` (K,) gets the inliers' correction."""
    eps, log_outlier = fp[F_EPS], fp[F_LOG_OUTLIER]
    for k in range(choice.shape[0]):
        robust[k] = 0.0
        if eps <= 0.0 or choice[k, m] < 0:
            continue
        inlier = math.log1p(-eps) + factor[k, m]
        combined = _logaddexp(inlier, log_outlier)
        if inlier < log_outlier:
            choice[k, m] = IGNORE
            factor[k, m] = combined
        else:
            robust[k] = combined - factor[k, m]


# ---------------------------------------------------------------------------- proposal
@njit(**_JIT)
def _propose_and_draw(m, state, mean, cov, ranges, bearings, noise_r, choice, fp, normals,
                      poses_out, info, b, a, cof, full, sigma, terms, picked, scored):
    """``proposal.observation_proposal`` (linearised once) from particle m's associated
    observations, then ``sample_pose`` from it into ``poses_out[m]`` (heading wrapped);
    returns the joint log likelihood of those observations. ``scored``: the pairs' terms,
    taken at the same mean, are in ``terms[picked[k]]`` (the same numbers, not recomputed)."""
    ox, oy, oyaw, noise_b = fp[F_OX], fp[F_OY], fp[F_OYAW], fp[F_NOISE_B]
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


# ---------------------------------------------------------------------------- map
@njit(**_JIT)
def _joseph(m, slot, k, state, px, py, lx, ly, heading, ranges, bearings, noise_r, noise_b,
            logodds_observed, logodds_max, confirmed):
    """Joseph-form EKF update (``update_landmarks``) of particle m's landmark ``slot`` by
    observation k, its log-odds raised (``existence.observed_logodds``: to ``logodds_max``
    from ``confirmed`` on); False if the result is not finite."""
    mx, my = state[m, slot, 0], state[m, slot, 1]
    sxx, sxy, syy = state[m, slot, 2], state[m, slot, 3], state[m, slot, 4]
    dx = mx - (px + lx)
    dy = my - (py + ly)
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    r0, r1 = noise_r[k], noise_b
    g00, g01 = dx / r, dy / r
    g10, g11 = -dy / q, dx / q
    a0, a1 = sxx * g00 + sxy * g01, sxy * g00 + syy * g01
    b0, b1 = sxx * g10 + sxy * g11, sxy * g10 + syy * g11
    s00 = g00 * a0 + g01 * a1 + r0
    s01 = g10 * a0 + g11 * a1
    s11 = g10 * b0 + g11 * b1 + r1
    det = s00 * s11 - s01 * s01
    i00, i01, i11 = s11 / det, -s01 / det, s00 / det
    k00, k01 = a0 * i00 + b0 * i01, a0 * i01 + b0 * i11
    k10, k11 = a1 * i00 + b1 * i01, a1 * i01 + b1 * i11
    nu0 = ranges[k] - r
    nu1 = _wrap(bearings[k] + heading - math.atan2(dy, dx))
    state[m, slot, 0] = mx + (k00 * nu0 + k01 * nu1)
    state[m, slot, 1] = my + (k10 * nu0 + k11 * nu1)
    a00, a01 = 1.0 - (k00 * g00 + k01 * g10), -(k00 * g01 + k01 * g11)
    a10, a11 = -(k10 * g00 + k11 * g10), 1.0 - (k10 * g01 + k11 * g11)
    m00, m01 = a00 * sxx + a01 * sxy, a00 * sxy + a01 * syy
    m10, m11 = a10 * sxx + a11 * sxy, a10 * sxy + a11 * syy
    state[m, slot, 2] = m00 * a00 + m01 * a01 + k00 * k00 * r0 + k01 * k01 * r1
    state[m, slot, 3] = m00 * a10 + m01 * a11 + k00 * k10 * r0 + k01 * k11 * r1
    state[m, slot, 4] = m10 * a10 + m11 * a11 + k10 * k10 * r0 + k11 * k11 * r1
    if state[m, slot, 5] >= confirmed:
        state[m, slot, 5] = logodds_max
    else:
        state[m, slot, 5] = min(state[m, slot, 5] + logodds_observed, logodds_max)
    finite = True
    for i in range(6):
        if not math.isfinite(state[m, slot, i]):
            finite = False
    return finite


@njit(**_JIT)
def _map_particle(m, state, valid, dirty, existing, choice, creator, poses, ranges, bearings,
                  noise_r, fp, observed, fresh):
    """``FastSLAM._apply_to_map`` and ``_missed_evidence`` for particle m, but for placing
    its new landmarks: the mean and packed covariance of each landmark it creates into
    ``fresh[k, m]`` (``_place_new`` puts them in their columns, known once every particle
    has chosen), the Joseph-form updates of its associated landmarks (observations in turn),
    then the log-odds of the landmarks in the perceptual range it did not observe and no
    observation it rejected explains (``existence``). False if an updated landmark is not
    finite (``FastSLAM.check_state`` then repairs)."""
    count = choice.shape[0]
    ox, oy, oyaw, noise_b = fp[F_OX], fp[F_OY], fp[F_OYAW], fp[F_NOISE_B]
    logodds_observed, logodds_max = fp[F_LOGODDS_OBSERVED], fp[F_LOGODDS_MAX]
    px, py, pth = poses[m, 0], poses[m, 1], poses[m, 2]
    lx, ly = _lever(pth, ox, oy)
    heading = pth + oyaw
    finite = True
    for j in range(existing):
        observed[j] = False
    for k in range(count):
        if choice[k, m] != NEW or creator[k] != k:
            continue
        # Mean g^-1(z, s), covariance G_m^-1 R G_m^-T (``initialize_landmarks``).
        c, s = math.cos(pth), math.sin(pth)
        sensor_x = px + c * ox - s * oy
        sensor_y = py + s * ox + c * oy
        angle = pth + oyaw + bearings[k]
        mx = sensor_x + ranges[k] * math.cos(angle)
        my = sensor_y + ranges[k] * math.sin(angle)
        dx = mx - (px + lx)
        dy = my - (py + ly)
        q = dx * dx + dy * dy
        r = math.sqrt(q)
        inv00, inv01 = r * dx / q, -dy
        inv10, inv11 = r * dy / q, dx
        r0 = noise_r[k]
        fresh[k, m, 0], fresh[k, m, 1] = mx, my
        fresh[k, m, 2] = inv00 * inv00 * r0 + inv01 * inv01 * noise_b
        fresh[k, m, 3] = inv00 * inv10 * r0 + inv01 * inv11 * noise_b
        fresh[k, m, 4] = inv10 * inv10 * r0 + inv11 * inv11 * noise_b
    for k in range(count):
        # Before ``_place_new`` every landmark chosen existed before this reading.
        slot = choice[k, m]
        if slot < 0:
            continue
        if not _joseph(m, slot, k, state, px, py, lx, ly, heading, ranges, bearings, noise_r,
                       noise_b, logodds_observed, logodds_max, fp[F_CONFIRMED]):
            finite = False
        dirty[m, slot] = True
        observed[slot] = True
    logodds_missed = fp[F_LOGODDS_MISSED]
    if logodds_missed == 0.0:
        return finite
    # Negative evidence on the landmarks that existed before this reading (the new ones were
    # all observed).
    min_range, max_range, field_of_view = fp[F_MIN_RANGE], fp[F_MAX_RANGE], fp[F_FOV]
    logodds_remove = fp[F_LOGODDS_REMOVE]
    confirmed, confirmed_missed = fp[F_CONFIRMED], fp[F_CONFIRMED_MISSED]
    gate = fp[F_EXPLAINED_GATE]
    limited = field_of_view < TWO_PI
    cos_half = math.cos(0.5 * field_of_view)
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    for j in range(existing):
        if not valid[m, j] or observed[j]:
            continue
        dx = state[m, j, 0] - (px + lx)
        dy = state[m, j, 1] - (py + ly)
        r = math.sqrt(dx * dx + dy * dy)
        if r < min_range or r > max_range:
            continue
        if limited and dx * cos_h + dy * sin_h < r * cos_half:
            continue
        # An observation the association rejected (it founded a landmark, not as a repeat of
        # an id, or was an outlier) near the landmark explains its absence
        # (``existence.explains``).
        predicted = math.atan2(dy, dx) - heading
        near = False
        for k in range(count):
            rejected = choice[k, m] == IGNORE or (choice[k, m] == NEW and creator[k] == k)
            if not rejected:
                continue
            range_error = ranges[k] - r
            bearing_error = _wrap(bearings[k] - predicted)
            if (range_error * range_error / noise_r[k]
                    + bearing_error * bearing_error / noise_b) <= gate:
                near = True
                break
        if near:
            continue
        if state[m, j, 5] >= confirmed:
            state[m, j, 5] += confirmed_missed
        else:
            state[m, j, 5] += logodds_missed
        dirty[m, j] = True
        if state[m, j, 5] < logodds_remove:
            valid[m, j] = False
    return finite


@njit(**_JIT)
def _place_new(state, ident, valid, dirty, is_new, existing, choice, creator, creating, column,
               keys, fresh, poses, ranges, bearings, labels, noise_r, fp, finite):
    """The new landmarks into their columns (``fresh``, from ``_map_particle``), then, with
    known ids, the updates of each by the later observations of its id in this reading
    (``choice`` points them at its column); ``finite[m]`` False for a non-finite update."""
    count, num_particles = choice.shape
    logodds_observed, logodds_max = fp[F_LOGODDS_OBSERVED], fp[F_LOGODDS_MAX]
    repeated = False
    for k in range(count):
        repeated = repeated or creator[k] != k
        slot = column[k]
        if slot < 0:
            continue
        for m in range(num_particles):
            if not creating[k, m]:
                continue
            for i in range(5):
                state[m, slot, i] = fresh[k, m, i]
            state[m, slot, 5] = logodds_observed
            ident[m, slot, 0] = labels[k]
            ident[m, slot, 1] = keys[k, m]
            valid[m, slot] = True
            is_new[m, slot] = True
            choice[k, m] = slot
    if not repeated:
        return
    ox, oy, oyaw, noise_b = fp[F_OX], fp[F_OY], fp[F_OYAW], fp[F_NOISE_B]
    for m in range(num_particles):
        for k in range(count):
            slot = choice[k, m]
            if slot < existing or creating[k, m]:
                continue
            px, py, pth = poses[m, 0], poses[m, 1], poses[m, 2]
            lx, ly = _lever(pth, ox, oy)
            if not _joseph(m, slot, k, state, px, py, lx, ly, pth + oyaw, ranges, bearings,
                           noise_r, noise_b, logodds_observed, logodds_max, fp[F_CONFIRMED]):
                finite[m] = False
            dirty[m, slot] = True


# ---------------------------------------------------------------------------- the reading
@njit(**_JIT)
def _clear_entry(m, j, row, slot, block, state, ident, valid, dirty, is_new):
    """Entry (m, j) empty, as a gathered working set leaves its free columns (a unit
    covariance, so that scoring it stays finite)."""
    for i in range(STATE_WIDTH):
        state[m, j, i] = 0.0
    state[m, j, 2] = state[m, j, 4] = 1.0
    ident[m, j, 0] = ident[m, j, 1] = -1
    row[m, j], slot[m, j], block[m, j] = -1, 0, -1
    valid[m, j] = dirty[m, j] = is_new[m, j] = False


@njit(**_JIT)
def _copy_entries(origin, m, existing, src_row, src_slot, src_block, src_state, src_ident,
                  src_valid, src_dirty, src_is_new, row, slot, block, state, ident, valid,
                  dirty, is_new):
    """Particle m's entries of the columns before ``existing`` become particle ``origin``'s
    of the source arrays."""
    for j in range(existing):
        row[m, j], slot[m, j], block[m, j] = (src_row[origin, j], src_slot[origin, j],
                                              src_block[origin, j])
        for i in range(STATE_WIDTH):
            state[m, j, i] = src_state[origin, j, i]
        ident[m, j, 0], ident[m, j, 1] = src_ident[origin, j, 0], src_ident[origin, j, 1]
        valid[m, j], dirty[m, j] = src_valid[origin, j], src_dirty[origin, j]
        is_new[m, j] = src_is_new[origin, j]


@njit(**_JIT)
def _take_particle(m, origin, existing, source, moved, state, ident, valid, dirty, is_new):
    """Particle m's working-set entries become particle ``origin``'s of ``source`` (row,
    slot, block, state, ident, valid, dirty, is_new; ``WorkingSet.take``); ``moved``: the
    row, slot and block arrays taking them. The columns from ``existing`` on are empty in
    every particle (new landmarks fill them in order, and ``first_new_slot`` follows), so they
    are written empty, not copied."""
    src_row, src_slot, src_block, src_state, src_ident, src_valid, src_dirty, src_is_new = \
        source
    row, slot, block = moved
    _copy_entries(origin, m, existing, src_row, src_slot, src_block, src_state, src_ident,
                  src_valid, src_dirty, src_is_new, row, slot, block, state, ident, valid,
                  dirty, is_new)
    for j in range(existing, valid.shape[1]):
        _clear_entry(m, j, row, slot, block, state, ident, valid, dirty, is_new)


@njit(**_JIT)
def _reading_chunk(counter, block, state, ident, valid, dirty, is_new, existing, mean, cov,
                   poses, ranges, bearings, labels, noise_r, draws, normals, log_weights, fp, ip,
                   resampled, source, moved, creator, choice, factor, poses_out, weights_out,
                   fresh, finite, recorded, turn, prior_cov):
    """Blocks of ``block`` particles taken from ``counter`` (``_claim``) until none is left,
    each particle in turn: its working-set entries taken from row ``resampled[m]`` of
    ``source`` (a resampling since the last reading; none when ``resampled`` is empty), with
    ``ip[I_MOTION]`` its prior covariance ``cov[m]`` propagated from ``prior_cov`` by the
    motion's ``turn`` (``advance_mean``), then association, outlier test, (FastSLAM 2.0)
    proposal and draw, the new log weight (before normalisation) and its map
    (``_map_particle``, the new landmarks left to ``_place_new``); ``finite[m]`` False for a
    non-finite update; the new pose also into ``recorded[m]`` (the path history's next
    generation); ``counter[1]`` counts the particles finished (``_Crew.run`` waits for
    it)."""
    count = ranges.shape[0]
    width = max(existing, 1)
    label = ident[:, :, 0]
    local = np.empty(width, np.int64)
    log_lik = np.empty((count, width))
    mahalanobis = np.empty((count, width))
    pick = np.empty(count, np.int64)
    value = np.empty(count)
    order = np.empty(width, np.int64)
    cumulative = np.empty(width + 1)
    inverse_q = np.empty(count)
    robust = np.empty(count)
    info, b, a = np.empty(9), np.empty(3), np.empty(9)
    cof, full, sigma = np.empty(9), np.empty(9), np.empty(9)
    terms = np.empty((width, 5))
    picked = np.empty(count, np.int64)
    observed = np.empty(width, np.bool_)
    scored = ip[I_MODE] != 0
    propose = ip[I_PROPOSE] != 0
    localization = ip[I_LOCALIZATION] != 0
    ordered = resampled.shape[0] > 0
    motion = ip[I_MOTION] != 0
    has_prior_cov = ip[I_PRIOR_COV] != 0
    num_particles = poses.shape[0]
    while True:
        lo = _claim(counter, 0, block)
        if lo >= num_particles:
            return
        hi = min(lo + block, num_particles)
        for m in range(lo, hi):
            if ordered:
                _take_particle(m, resampled[m], existing, source, moved, state, ident, valid,
                               dirty, is_new)
            if motion:
                _propagate_cov(m, turn, prior_cov, has_prior_cov, fp[F_MOTION + 1],
                               fp[F_MOTION + 3], fp[F_MOTION + 4], fp[F_MOTION + 5], cov)
            _associate_particle(m, state, valid, label, existing, mean, cov, ranges,
                                bearings, labels, noise_r, draws, fp, ip, choice, factor,
                                inverse_q, local, log_lik, mahalanobis, pick, value, order,
                                cumulative, terms, picked)
            _reject_outliers(m, choice, factor, robust, fp)
            if localization:
                # A fixed map takes no new landmark: an unexplained observation weighs p0.
                for k in range(count):
                    if choice[k, m] == NEW:
                        choice[k, m] = IGNORE
            if propose:
                joint = _propose_and_draw(m, state, mean, cov, ranges, bearings, noise_r,
                                          choice, fp, normals, poses_out, info, b, a, cof,
                                          full, sigma, terms, picked, scored)
                # The associated observations weigh their joint likelihood (on the first row)
                # times 1 / q (``FastSLAM._sample_proposal``).
                for k in range(count):
                    if choice[k, m] >= 0:
                        factor[k, m] = inverse_q[k]
                if count:
                    factor[0, m] += joint
            else:
                poses_out[m, 0], poses_out[m, 1], poses_out[m, 2] = (
                    poses[m, 0], poses[m, 1], poses[m, 2])
            total = 0.0
            for k in range(count):
                factor[k, m] = factor[k, m] + robust[k]
                total += factor[k, m]
            weights_out[m] = log_weights[m] + total
            finite[m] = localization or _map_particle(m, state, valid, dirty, existing,
                                                      choice, creator, poses_out, ranges,
                                                      bearings, noise_r, fp, observed, fresh)
            recorded[m, 0], recorded[m, 1], recorded[m, 2] = (
                poses_out[m, 0], poses_out[m, 1], poses_out[m, 2])
        _claim(counter, 1, hi - lo)


@njit(**_JIT)
def _assign_columns(choice, labels, known, existing, first_key, creating, column, keys):
    """Which pairs create a landmark (``creating``), the working-set column of each creating
    observation (one per observation that creates in some particle, from ``existing`` on) and
    the keys of the new landmarks (observation-major from ``first_key``); with known ids a
    repeated id updates the landmark its first observation creates. Returns (columns taken,
    keys taken)."""
    count, num_particles = choice.shape
    taken = 0
    for k in range(count):
        creator = k
        if known:
            for other in range(k):
                if labels[other] == labels[k]:
                    creator = other
                    break
        any_new = False
        for m in range(num_particles):
            creating[k, m] = choice[k, m] == NEW and creator == k
            any_new = any_new or creating[k, m]
        column[k] = -1
        if any_new:
            column[k] = existing + taken
            taken += 1
        if creator != k:
            for m in range(num_particles):
                if choice[k, m] == NEW:
                    choice[k, m] = column[creator]
    new_keys = 0
    for k in range(count):
        for m in range(num_particles):
            keys[k, m] = -1
            if creating[k, m]:
                keys[k, m] = first_key + new_keys
                new_keys += 1
    return taken, new_keys


@njit(**_JIT)
def _normalize(log_weights, weights):
    """``resampling.normalize_log_weights`` in place, the weights themselves into
    ``weights`` (their exponentials, without a second pass of them); returns underflow."""
    count = log_weights.shape[0]
    peak = -np.inf
    for m in range(count):
        if math.isnan(log_weights[m]):
            log_weights[m] = -np.inf
        elif log_weights[m] > peak:
            peak = log_weights[m]
    if not math.isfinite(peak):
        for m in range(count):
            log_weights[m] = -math.log(count)
            weights[m] = 1.0 / count
        return True
    total = 0.0
    for m in range(count):
        log_weights[m] -= peak
        weights[m] = math.exp(log_weights[m])
        total += weights[m]
    log_total = math.log(total)
    for m in range(count):
        log_weights[m] -= log_total
        weights[m] /= total
    return False


@njit(**_JIT)
def _finish(poses, log_weights, central, finite):
    """Normalise the log weights; (N_eff, underflow, the reported particle, all finite)."""
    count = log_weights.shape[0]
    weights = np.empty(count)
    underflow = _normalize(log_weights, weights)
    squares = mean_x = mean_y = 0.0
    best, heaviest = 0, log_weights[0]
    for m in range(count):
        weight = weights[m]
        squares += weight * weight
        mean_x += weight * poses[m, 0]
        mean_y += weight * poses[m, 1]
        if log_weights[m] > heaviest:
            best, heaviest = m, log_weights[m]
        for i in range(3):
            if not math.isfinite(poses[m, i]):
                finite[m] = False
    if central:
        nearest = np.inf
        for m in range(count):
            dx, dy = poses[m, 0] - mean_x, poses[m, 1] - mean_y
            distance = dx * dx + dy * dy
            if distance < nearest:
                best, nearest = m, distance
    all_finite = True
    for m in range(count):
        all_finite = all_finite and finite[m]
    return 1.0 / squares, underflow, best, all_finite


@njit(**_JIT)
def _report(choice, creating, ident, best):
    """``UpdateReport.associated_ids`` and ``is_new`` of particle ``best``."""
    count = choice.shape[0]
    ids = np.full(count, -1, np.int64)
    is_new = np.empty(count, np.bool_)
    for k in range(count):
        is_new[k] = creating[k, best]
        if choice[k, best] >= 0 and not is_new[k]:
            ids[k] = ident[best, choice[k, best], 0]
    return ids, is_new


@njit(**_JIT)
def _noise_ranges(ranges, fp):
    """Range variance of every observation (``FastSLAM._noise``)."""
    noise_r = np.empty(ranges.shape[0])
    per_meter = fp[F_NOISE_R_PER_M]
    for k in range(ranges.shape[0]):
        noise_r[k] = fp[F_NOISE_R]
        if per_meter != 0.0:
            noise_r[k] = fp[F_NOISE_R] + (per_meter * ranges[k]) ** 2
    return noise_r


@njit(**_JIT)
def _reading_buffers(ranges, labels, num_particles, fp, ip):
    """Range variances, the observation whose landmark each observation creates (itself; with
    known ids the first of its id) and the per-reading outputs of the chunks."""
    count = ranges.shape[0]
    creator = np.arange(count)
    if ip[I_MODE] == 0:
        for k in range(count):
            for other in range(k):
                if labels[other] == labels[k]:
                    creator[k] = other
                    break
    return (_noise_ranges(ranges, fp), creator, np.empty((count, num_particles), np.int64),
            np.empty((count, num_particles)), np.empty((num_particles, 3)),
            np.empty(num_particles), np.empty((count, num_particles, 5)),
            np.ones(num_particles, np.bool_))


@njit(**_JIT)
def _settle(state, ident, valid, dirty, is_new, existing, choice, creator, fresh, poses_out,
            weights_out, ranges, bearings, labels, noise_r, fp, ip, finite):
    """After every chunk: the columns and keys of the new landmarks, which are put in place,
    the weights normalised, N_eff, the reported particle and its report."""
    count, num_particles = choice.shape
    creating = np.empty((count, num_particles), np.bool_)
    column = np.empty(count, np.int64)
    keys = np.empty((count, num_particles), np.int64)
    taken, new_keys = _assign_columns(choice, labels, ip[I_MODE] == 0, existing,
                                      ip[I_FIRST_KEY], creating, column, keys)
    if ip[I_LOCALIZATION] == 0:
        _place_new(state, ident, valid, dirty, is_new, existing, choice, creator, creating,
                   column, keys, fresh, poses_out, ranges, bearings, labels, noise_r, fp, finite)
    n_eff, underflow, best, all_finite = _finish(poses_out, weights_out, ip[I_CENTRAL] != 0,
                                                 finite)
    report_ids, report_new = _report(choice, creating, ident, best)
    return (report_ids, report_new, poses_out, weights_out, n_eff, underflow, best, taken,
            new_keys, all_finite)


@njit(**_JIT)
def _reading_serial(state, ident, valid, dirty, is_new, existing, mean, cov, poses, ranges,
                    bearings, labels, draws, normals, log_weights, fp, ip, order, source, moved,
                    recorded, turn, prior_cov):
    """The whole reading on the calling thread (``update_reading``)."""
    num_particles = poses.shape[0]
    noise_r, creator, choice, factor, poses_out, weights_out, fresh, finite = _reading_buffers(
        ranges, labels, num_particles, fp, ip)
    _reading_chunk(np.zeros(2, np.int64), num_particles, state, ident, valid, dirty, is_new,
                   existing, mean, cov, poses, ranges, bearings, labels, noise_r, draws,
                   normals, log_weights, fp, ip, order, source, moved, creator, choice, factor,
                   poses_out, weights_out, fresh, finite, recorded, turn, prior_cov)
    return _settle(state, ident, valid, dirty, is_new, existing, choice, creator, fresh,
                   poses_out, weights_out, ranges, bearings, labels, noise_r, fp, ip, finite)


def _reading_threaded(state, ident, valid, dirty, is_new, existing, mean, cov, poses, ranges,
                      bearings, labels, draws, normals, log_weights, fp, ip, order, source,
                      moved, recorded, turn, prior_cov, chunks):
    """``_reading_serial`` with its per-particle work shared by ``chunks`` threads: the
    calling thread and the crew's (``_Crew``), one hand-off per reading, each taking
    blocks of ``READING_BLOCK`` particles from one counter until none is left (so a thread
    that starts late or runs slower takes fewer). Blocks write disjoint particles, so the
    results are those of the serial reading."""
    num_particles = poses.shape[0]
    noise_r, creator, choice, factor, poses_out, weights_out, fresh, finite = _reading_buffers(
        ranges, labels, num_particles, fp, ip)
    _run_shared(_reading_chunk, chunks, (
        np.zeros(2, np.int64), READING_BLOCK, state, ident, valid, dirty, is_new, existing, mean,
        cov, poses, ranges, bearings, labels, noise_r, draws, normals, log_weights, fp, ip, order,
        source, moved, creator, choice, factor, poses_out, weights_out, fresh, finite,
        recorded, turn, prior_cov), num_particles)
    return _settle(state, ident, valid, dirty, is_new, existing, choice, creator, fresh,
                   poses_out, weights_out, ranges, bearings, labels, noise_r, fp, ip, finite)


_crew: _Crew | None = None


def _shared_crew() -> _Crew:
    """The worker threads of ``_reading_threaded`` and ``_run_chunks`` (made on first use,
    as many as the threads beyond the calling one)."""
    global _crew
    if _crew is None:
        _crew = _Crew(max(1, _max_threads - 1))
    return _crew


def _chunk_bounds(num_particles: int, chunks: int) -> list[tuple[int, int]]:
    """(lo, hi) of ``chunks`` nearly equal chunks of the particles."""
    return [(c * num_particles // chunks, (c + 1) * num_particles // chunks)
            for c in range(chunks)]


READING_BLOCK = 16
"""Particles a thread of a split reading takes at a time: small enough that the threads end
within about one block of each other (a particle costs a few microseconds), large enough that
taking one costs nothing."""


def _run_shared(kernel, threads: int, args, total: int) -> None:
    """``kernel(*args)`` on this thread and on ``threads - 1`` worker threads at once (the
    kernel shares the work out itself, ``_Crew``); returns when all ``total`` particles are
    done (a worker's exception is raised here)."""
    _shared_crew().run(kernel, threads - 1, args, total)


DONE_POLLS = 200_000
"""Polls of the particles-done counter (about 1.5 ms) before the calling thread of a split
reading waits by sleeping instead (a worker thread descheduled in the middle of a block)."""


class _Crew:
    """The worker threads of the split readings, kept from one reading to the next, each
    serving its own queue. A reading puts its job in the queues and runs its own share at
    once; the threads take blocks of particles from the reading's counter and count the
    particles they finish, and the reading waits for that count in compiled code, without
    the GIL. A worker that starts late only takes fewer blocks, and no reading waits for a
    worker to wake up or to return to Python."""

    def __init__(self, workers: int) -> None:
        self._queues = [queue.SimpleQueue() for _ in range(workers)]
        self._errors: list[BaseException] = []
        for number, jobs in enumerate(self._queues):
            threading.Thread(target=self._serve, args=(jobs,), daemon=True,
                             name=f"fastslam_kernel_{number}").start()

    def _serve(self, jobs) -> None:
        while True:
            job = jobs.get()
            if job is None:
                return
            kernel, args, reply = job
            error = None
            try:
                kernel(*args)
            except BaseException as caught:  # noqa: BLE001 (raised on the calling thread)
                error = caught
            if reply is not None:
                reply.put(error)
            elif error is not None:
                self._errors.append(error)

    def run(self, kernel, workers: int, args, total: int) -> None:
        """``kernel(*args)`` here and on ``workers`` of the threads, the kernel taking its
        blocks from the reading's counter ``args[0]`` and counting the particles it finished
        in it; returns when all ``total`` are done (a worker's exception is raised here)."""
        for jobs in self._queues[:workers]:
            jobs.put((kernel, args, None))
        kernel(*args)
        counter = args[0]
        while not _await_done(counter, total, DONE_POLLS):
            if self._errors:
                break
            time.sleep(1e-4)
        if self._errors:
            error = self._errors.pop()
            self._errors.clear()
            raise error

    def run_each(self, kernel, argument_sets) -> None:
        """``kernel(*arguments)`` for each of ``argument_sets``: the first here, each other on
        a worker of its own; returns when all are done (a worker's exception is raised
        here)."""
        if len(argument_sets) - 1 > len(self._queues):
            raise ValueError(f"{len(argument_sets)} jobs for {len(self._queues)} workers and "
                             "the calling thread")
        reply = queue.SimpleQueue()
        for jobs, arguments in zip(self._queues, argument_sets[1:]):
            jobs.put((kernel, arguments, reply))
        kernel(*argument_sets[0])
        errors = [reply.get() for _ in argument_sets[1:]]
        for error in errors:
            if error is not None:
                raise error

    def stop(self) -> None:
        for jobs in self._queues:
            jobs.put(None)


def _run_chunks(kernel, bounds, args) -> None:
    """``kernel(lo, hi, *args)`` for every (lo, hi) of ``bounds``: the first on this thread,
    the others on the crew's workers; returns when all are done (a worker's exception is
    raised here)."""
    _shared_crew().run_each(kernel, [(lo, hi, *args) for lo, hi in bounds])


@njit(**_JIT)
def _usable_kernel(ranges, bearings, labels, known, min_range):
    count = 0
    for k in range(ranges.shape[0]):
        count += (math.isfinite(ranges[k]) and math.isfinite(bearings[k])
                  and ranges[k] >= min_range and (labels[k] >= 0 or not known))
    kept_ranges, kept_bearings = np.empty(count), np.empty(count)
    kept_labels = np.empty(count, np.int64)
    farthest = 0.0
    i = 0
    for k in range(ranges.shape[0]):
        if (math.isfinite(ranges[k]) and math.isfinite(bearings[k]) and ranges[k] >= min_range
                and (labels[k] >= 0 or not known)):
            kept_ranges[i], kept_bearings[i] = ranges[k], _wrap(bearings[k])
            kept_labels[i] = labels[k]
            farthest = max(farthest, ranges[k])
            i += 1
    return kept_ranges, kept_bearings, kept_labels, farthest


def usable_observations(ranges: np.ndarray, bearings: np.ndarray, labels: np.ndarray,
                        known: bool, min_range: float):
    """The gating of ``FastSLAM.update``: the observations with a finite range of at least
    ``min_range``, a finite bearing (wrapped) and, with ``known`` ids, an id >= 0; with the
    largest kept range (0 when none is kept)."""
    return _usable_kernel(np.ascontiguousarray(ranges), np.ascontiguousarray(bearings),
                          np.ascontiguousarray(labels), known, min_range)


@njit(**_JIT)
def _box_kernel(poses):
    low_x, low_y = poses[0, 0], poses[0, 1]
    high_x, high_y = low_x, low_y
    for m in range(1, poses.shape[0]):
        low_x, high_x = min(low_x, poses[m, 0]), max(high_x, poses[m, 0])
        low_y, high_y = min(low_y, poses[m, 1]), max(high_y, poses[m, 1])
    return low_x, low_y, high_x, high_y


def pose_box(poses: np.ndarray) -> tuple[float, float, float, float]:
    """(lowest x, lowest y, highest x, highest y) of the poses (M, 3), M >= 1."""
    return _box_kernel(poses)


class ReadingSettings(NamedTuple):
    """The filter's constants in the kernels' layout (``F_*`` floats, ``I_*`` integers)."""

    floats: np.ndarray
    integers: np.ndarray


def reading_settings(config, offset, log_p0: float, log_outlier: float,
                     logodds_max: float) -> ReadingSettings:
    """``ReadingSettings`` of a validated ``FastSLAMConfig`` (the per-reading entries, reach,
    first key and which stages run, are filled by ``update_reading``)."""
    floats = np.zeros(NUM_F)
    floats[[F_OX, F_OY, F_OYAW]] = offset.x, offset.y, offset.yaw
    floats[F_NOISE_R] = config.sigma_range ** 2
    floats[F_NOISE_R_PER_M] = config.sigma_range_per_meter
    floats[F_NOISE_B] = config.sigma_bearing ** 2
    floats[F_LOG_P0], floats[F_GATE] = log_p0, config.association_gate
    floats[F_NEW_GATE] = config.new_landmark_gate
    floats[F_EPS], floats[F_LOG_OUTLIER] = config.outlier_probability, log_outlier
    floats[[F_MIN_RANGE, F_MAX_RANGE, F_FOV]] = (config.min_range, config.max_range,
                                                 config.field_of_view)
    floats[[F_LOGODDS_OBSERVED, F_LOGODDS_MISSED, F_LOGODDS_REMOVE, F_LOGODDS_MAX]] = (
        *config.existence_evidence(), config.logodds_remove, logodds_max)
    floats[[F_CONFIRMED, F_CONFIRMED_MISSED]] = config.confirmation()
    floats[F_EXPLAINED_GATE] = EXPLAINED_GATE
    floats[F_ALPHAS:F_ALPHAS + 4] = (config.alpha1, config.alpha2, config.alpha3, config.alpha4)
    floats[F_MIN_TRANSLATION_SIGMA] = config.min_translation_sigma
    floats[F_MIN_ROTATION_SIGMA] = config.min_rotation_sigma
    floats[F_LINEAR_NOISE:F_LINEAR_NOISE + 4] = (
        config.rotation_variance_per_radian, config.rotation_variance_per_meter,
        config.translation_variance_per_meter, config.translation_variance_per_radian)
    integers = np.zeros(NUM_I, np.int64)
    integers[I_MODE] = MODE_CODES[config.association]
    integers[I_LOCALIZATION] = config.mode == "localization"
    integers[I_CENTRAL] = config.best_particle == "central"
    return ReadingSettings(floats, integers)


_NO_COV = np.zeros((1, 3, 3))
_NO_TURN = np.zeros((0, 2))
_NO_ORDER = np.zeros(0, np.int64)


def update_reading(ws, mean, cov, poses, ranges, bearings, labels, draws, normals,
                   log_weights, settings: ReadingSettings, reach: float, first_key: int,
                   propose: bool, recorded: np.ndarray, order: np.ndarray | None = None,
                   motion=None):
    """One reading for every particle, on the working set ``ws`` (updated in place), or, with
    ``order`` (a resampling not yet applied to ``ws``), on a new one whose particle m takes the
    entries of ``ws``'s particle ``order[m]`` (``WorkingSet.take``, in the reading's chunks).

    ``mean`` (M, 3) and ``cov`` (M, 3, 3) or None: the pose the observations are scored at and
    its covariance (the FastSLAM 2.0 prior; None: the particles' poses ``poses``, which
    ``mean`` then is); ``draws``: the (K * M) uniforms of ``monte_carlo``; ``normals``: the
    (M, 3) standard normals of the proposal's draw when ``propose``; ``first_key``: the
    store's next landmark key; ``recorded`` (M, 3): also given the new poses (the path
    history's next generation, ``PathHistory.next_generation``); ``motion``: the prior's
    turn, cov (or None) ``mean`` was moved from and the motion (``advance_mean``): the
    reading propagates the covariance in its blocks (then ``cov`` is None). Returns (the reported
    particle's ``UpdateReport`` associated_ids (K,) and is_new (K,), poses (M, 3), normalised
    log weights (M,), N_eff, underflow, the reported particle, working-set columns taken, keys
    taken, all finite, the working set read).
    """
    return _update(ws, mean, cov, poses, ranges, bearings, labels, draws, normals, log_weights,
                   settings, reach, first_key, propose, recorded, order,
                   _threads_for(poses.shape[0]), motion)


def _update(ws, mean, cov, poses, ranges, bearings, labels, draws, normals, log_weights,
            settings: ReadingSettings, reach: float, first_key: int, propose: bool, recorded,
            order, threads: int, motion=None):
    """``update_reading`` on ``threads`` threads."""
    ip = settings.integers
    ip[I_MOTION] = motion is not None
    if motion is None:
        turn, prior_cov = _NO_TURN, _NO_COV
    else:
        turn, prior_cov, values = motion
        settings.floats[F_MOTION:F_MOTION + 6] = values
        ip[I_PRIOR_COV] = prior_cov is not None
        if prior_cov is None:
            prior_cov = _NO_COV
        cov = np.empty((poses.shape[0], 3, 3))
    source = (ws.row, ws.slot, ws.block, ws.state, ws.ident, ws.valid, ws.dirty, ws.is_new)
    if order is None:
        order = _NO_ORDER
    else:
        ws = WorkingSet(*(np.empty_like(array) for array in source[:3]), ws.columns[order],
                        *(np.empty_like(array) for array in source[3:]), ws.first_new_slot)
    args = _reading_args(ws, mean, cov, poses, ranges, bearings, labels, draws, normals,
                         log_weights, settings, reach, first_key, propose) + (
        order, source, (ws.row, ws.slot, ws.block), recorded, turn, prior_cov)
    if threads == 1:
        return _reading_serial(*args) + (ws,)
    return _reading_threaded(*args, threads) + (ws,)


def _reading_args(ws, mean, cov, poses, ranges, bearings, labels, draws, normals, log_weights,
                  settings: ReadingSettings, reach: float, first_key: int, propose: bool):
    """The arguments of ``_reading_serial`` / ``_reading_threaded`` (the reading's entries
    of the settings filled in)."""
    fp, ip = settings
    has_cov = cov is not None
    fp[F_REACH] = reach
    ip[I_FIRST_KEY] = first_key
    ip[I_HAS_COV] = has_cov
    ip[I_PROPOSE] = propose
    # FastSLAM 2.0 weighs the associated observations by the proposal's joint likelihood,
    # and without an outlier test nothing needs the likelihood of a known id's landmark.
    ip[I_SCORE_KNOWN] = not (has_cov and fp[F_EPS] == 0.0)
    return (ws.state, ws.ident, ws.valid, ws.dirty, ws.is_new, ws.first_new_slot, mean,
            cov if has_cov else _NO_COV, poses, np.ascontiguousarray(ranges),
            np.ascontiguousarray(bearings), np.ascontiguousarray(labels), draws, normals,
            log_weights, fp, ip)


# ---------------------------------------------------------------------------- motion
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
def _motion_of(dx, dy, dtheta, fp):
    """The odometry delta's (rot1, trans, rot2) (``OdometryControl.from_delta``) and their
    variances (``motion.control_variances``)."""
    trans = math.hypot(dx, dy)
    rot1 = math.atan2(dy, dx) if trans > 1e-9 else 0.0
    if abs(rot1) > math.pi / 2.0:
        rot1 = _wrap(rot1 - math.pi)
        trans = -trans
    rot2 = _wrap(dtheta - rot1)
    a1, a2, a3, a4 = fp[F_ALPHAS], fp[F_ALPHAS + 1], fp[F_ALPHAS + 2], fp[F_ALPHAS + 3]
    min_t, min_r = fp[F_MIN_TRANSLATION_SIGMA], fp[F_MIN_ROTATION_SIGMA]
    rot1_sq, trans_sq, rot2_sq = rot1 ** 2, trans ** 2, rot2 ** 2
    v_rot1 = a1 * rot1_sq + a2 * trans_sq + min_r ** 2
    v_trans = a3 * trans_sq + a4 * (rot1_sq + rot2_sq) + min_t ** 2
    v_rot2 = a1 * rot2_sq + a2 * trans_sq + min_r ** 2
    k_rr, k_rt = fp[F_LINEAR_NOISE], fp[F_LINEAR_NOISE + 1]
    k_tt, k_tr = fp[F_LINEAR_NOISE + 2], fp[F_LINEAR_NOISE + 3]
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
def _advance_mean_kernel(mean, cov, has_cov, dx, dy, dtheta, fp):
    motion = np.array(_motion_of(dx, dy, dtheta, fp))
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
    return _advance_mean_kernel(mean, cov, prior is not None, *delta, settings.floats)


def propagate_cov(turn: np.ndarray, cov: np.ndarray | None, motion: np.ndarray) -> np.ndarray:
    """``propagate_gaussian``'s covariance of the prior (cov None: zero) through the motion
    and turn of ``advance_mean``."""
    return _propagate_cov_kernel(turn, _NO_COV if cov is None else cov, cov is not None,
                                 motion)


# ---------------------------------------------------------------------------- resampling
@njit(**_JIT)
def _systematic_kernel(weights, offset):
    count = weights.shape[0]
    cumulative = np.cumsum(weights)
    cumulative[count - 1] = 1.0  # as ``resampling._cumulative``
    indices = np.empty(count, np.int64)
    source = 0
    for m in range(count):
        # searchsorted(side="right") of the sorted positions: one merge pass.
        position = (offset + m) / count
        while source < count - 1 and cumulative[source] <= position:
            source += 1
        indices[m] = source
    return indices


@njit(**_JIT)
def _take_rows(indices, source):
    """source[indices] along the first axis, element by element (numba's slice copies are
    slower than numpy's)."""
    width = 1
    for extent in source.shape[1:]:
        width *= extent
    flat = source.reshape((source.shape[0], width))
    out = np.empty((indices.shape[0], flat.shape[1]), flat.dtype)
    for m in range(indices.shape[0]):
        row = indices[m]
        for i in range(flat.shape[1]):
            out[m, i] = flat[row, i]
    return out.reshape((indices.shape[0],) + source.shape[1:])


@njit(**_JIT)
def _take_kernel(indices, row, slot, block, state, ident, valid, dirty, is_new):
    return (_take_rows(indices, row), _take_rows(indices, slot), _take_rows(indices, block),
            _take_rows(indices, state), _take_rows(indices, ident), _take_rows(indices, valid),
            _take_rows(indices, dirty), _take_rows(indices, is_new))


def take(ws, indices: np.ndarray):
    """``WorkingSet.take``: the working set after resampling, its entries in one compiled
    pass (``columns``, which may be a read-only broadcast, by numpy)."""
    row, slot, block, state, ident, valid, dirty, is_new = _take_kernel(
        indices, ws.row, ws.slot, ws.block, ws.state, ws.ident, ws.valid, ws.dirty, ws.is_new)
    return WorkingSet(row, slot, block, ws.columns[indices], state, ident, valid, dirty, is_new,
                      ws.first_new_slot)


@njit(**_JIT)
def _reindex_kernel(indices, existing, row, slot, block, state, ident, valid, dirty, is_new):
    """``_take_kernel`` in place for non-decreasing ``indices`` (systematic resampling's, and
    their compositions): rows that move up are copied in ascending order, rows that move down
    in descending order, so every source is read before it is overwritten; rows that keep
    their place are not touched, nor are the columns from ``existing`` on (empty in every
    particle). False, and nothing changed, for other indices."""
    count = indices.shape[0]
    for m in range(1, count):
        if indices[m] < indices[m - 1]:
            return False
    for m in range(count):
        if indices[m] > m:
            _copy_entries(indices[m], m, existing, row, slot, block, state, ident, valid,
                          dirty, is_new, row, slot, block, state, ident, valid, dirty, is_new)
    for m in range(count - 1, -1, -1):
        if indices[m] < m:
            _copy_entries(indices[m], m, existing, row, slot, block, state, ident, valid,
                          dirty, is_new, row, slot, block, state, ident, valid, dirty, is_new)
    return True


def reindex(ws, indices: np.ndarray):
    """``take`` for a working set no longer needed as it was: in place when ``indices`` are
    non-decreasing (``_reindex_kernel``), else a copy."""
    if not _reindex_kernel(indices, ws.first_new_slot, ws.row, ws.slot, ws.block, ws.state,
                           ws.ident, ws.valid, ws.dirty, ws.is_new):
        return take(ws, indices)
    ws.columns = ws.columns[indices]
    return ws


@njit(**_JIT)
def _resample_poses_kernel(weights, offset, poses, best):
    indices = _systematic_kernel(weights, offset)
    count = indices.shape[0]
    moved = np.empty((count, 3))
    copy = -1
    for m in range(count):
        source = indices[m]
        moved[m, 0], moved[m, 1], moved[m, 2] = poses[source, 0], poses[source, 1], \
            poses[source, 2]
        if copy < 0 and source == best:
            copy = m
    return indices, moved, copy


def resample_poses(weights: np.ndarray, rng: np.random.Generator, poses: np.ndarray,
                   best: int):
    """``resampling.systematic_resample`` (on the same weights and draw, the same indices) and
    what follows it in one call: (indices, the resampled poses, the first copy of particle
    ``best``, -1 when none was drawn)."""
    return _resample_poses_kernel(weights, rng.random(), poses, best)


# ---------------------------------------------------------------------------- path history
@njit(**_JIT)
def _ranks(values):
    """(the distinct values, sorted; each value's index among them) of non-negative integers:
    ``np.unique`` and ``np.searchsorted`` on it, through a marker."""
    size = 0
    for v in values:
        size = max(size, v + 1)
    rank = np.zeros(size, np.int64)
    for v in values:
        rank[v] = 1
    count = 0
    for i in range(size):
        if rank[i]:
            rank[i] = count
            count += 1
    distinct = np.empty(count, np.int64)
    positions = np.empty(values.shape[0], np.int64)
    for k in range(values.shape[0]):
        positions[k] = rank[values[k]]
        distinct[positions[k]] = values[k]
    return distinct, positions


@njit(**_JIT)
def _prune_kernel(leaf, parents, poses, widths, count):
    """``PathHistory._prune_generations_numpy`` in place: the kept nodes of each of the first
    ``count`` generations moved to its start (in their order, so no node is overwritten
    before it is read); returns the new leaf."""
    alive, new_leaf = _ranks(leaf)
    for g in range(count - 1, -1, -1):
        width = alive.shape[0]
        chosen = np.empty(width, np.int64)
        for i in range(width):
            source = alive[i]
            chosen[i] = parents[g, source]
            poses[g, i, 0], poses[g, i, 1], poses[g, i, 2] = (poses[g, source, 0],
                                                              poses[g, source, 1],
                                                              poses[g, source, 2])
        alive, positions = _ranks(chosen)
        for i in range(width):
            parents[g, i] = positions[i]
        widths[g] = width
    return new_leaf


def prune(leaf: np.ndarray, parents: np.ndarray, poses: np.ndarray, widths: np.ndarray,
          count: int) -> np.ndarray:
    """``PathHistory._prune_generations_numpy`` in one call on the history's arrays (parents
    (G, M), poses (G, M, 3), widths (G,), changed in place; the first ``count`` generations);
    returns the new leaf."""
    return _prune_kernel(leaf, parents, poses, widths, count)


@njit(**_JIT)
def _gather_layout(table, columns, occupied, num_new_slots):
    """The working set's arrays (unfilled) for the cell ``columns`` and its width: the most
    landmarks any particle has there."""
    num_particles, num_columns = columns.shape
    width = 0
    for m in range(num_particles):
        count = 0
        for c in range(num_columns):
            if columns[m, c] >= 0 and table[m, columns[m, c]] >= 0:
                for s in range(occupied.shape[1]):
                    count += occupied[table[m, columns[m, c]], s]
        width = max(width, count)
    shape = (num_particles, width + num_new_slots)
    return (np.empty(shape, np.int64), np.empty(shape, np.int64), np.empty(shape, np.int64),
            np.empty(shape + (STATE_WIDTH,)), np.empty(shape + (2,), np.int64),
            np.empty(shape, np.bool_), np.empty(shape, np.bool_), np.empty(shape, np.bool_),
            width)


@njit(**_JIT)
def _gather_chunk(lo, hi, table, columns, occupied, pool_state, pool_ident, row, slot, block,
                  state, ident, valid, dirty, is_new):
    """Particles [lo, hi) of the working set (``_gather_layout``'s arrays): their landmarks
    of the cell ``columns`` in column then slot order, then empty entries (a unit covariance,
    so that scoring them stays finite)."""
    total = valid.shape[1]
    for m in range(lo, hi):
        rank = 0
        for c in range(columns.shape[1]):
            if columns[m, c] < 0 or table[m, columns[m, c]] < 0:
                continue
            source = table[m, columns[m, c]]
            for s in range(occupied.shape[1]):
                if not occupied[source, s]:
                    continue
                for i in range(STATE_WIDTH):
                    state[m, rank, i] = pool_state[source, s, i]
                ident[m, rank, 0] = pool_ident[source, s, 0]
                ident[m, rank, 1] = pool_ident[source, s, 1]
                row[m, rank], slot[m, rank], block[m, rank] = source, s, c
                valid[m, rank] = True
                rank += 1
        for j in range(rank, total):
            for i in range(STATE_WIDTH):
                state[m, j, i] = 0.0
            state[m, j, 2] = state[m, j, 4] = 1.0
            ident[m, j, 0] = ident[m, j, 1] = -1
            row[m, j], slot[m, j], block[m, j] = -1, 0, -1
            valid[m, j] = False
        for j in range(total):
            dirty[m, j] = is_new[m, j] = False


@njit(**_JIT)
def _gather_kernel(table, columns, occupied, pool_state, pool_ident, num_new_slots):
    row, slot, block, state, ident, valid, dirty, is_new, width = _gather_layout(
        table, columns, occupied, num_new_slots)
    _gather_chunk(0, columns.shape[0], table, columns, occupied, pool_state, pool_ident, row,
                  slot, block, state, ident, valid, dirty, is_new)
    return row, slot, block, state, ident, valid, dirty, is_new, width


def gather(store: LandmarkStore, columns: np.ndarray, num_new_slots: int) -> WorkingSet:
    """``LandmarkStore.gather`` (which brings the gathered columns up to date first): the same
    working set, in one compiled pass over the cells (from ``PARALLEL_MIN_PARTICLES`` on, one
    chunk of particles per thread)."""
    return _gather(store, columns, num_new_slots, _threads_for(store.num_particles))


def _gather(store: LandmarkStore, columns: np.ndarray, num_new_slots: int,
            threads: int) -> WorkingSet:
    """``gather`` on ``threads`` threads."""
    tables = (store.table, np.require(columns, np.int64, ("C", "W")), store.occupied)
    pool = (store.state, store.ident)
    if threads == 1:
        arrays = _gather_kernel(*tables, *pool, num_new_slots)
    else:
        arrays = _gather_layout(*tables, num_new_slots)
        _run_chunks(_gather_chunk, _chunk_bounds(store.num_particles, threads),
                    tables + pool + arrays[:8])
    row, slot, block, state, ident, valid, dirty, is_new, width = arrays
    return WorkingSet(row=row, slot=slot, block=block, columns=columns, state=state,
                      ident=ident, valid=valid, dirty=dirty, is_new=is_new,
                      first_new_slot=int(width))


@njit(**_JIT)
def _block_records_kernel(rows, occupied, pool_state, pool_ident):
    count = 0
    for i in range(rows.shape[0]):
        if rows[i] >= 0:
            for s in range(occupied.shape[1]):
                count += occupied[rows[i], s]
    state = np.empty((count, pool_state.shape[2]))
    ident = np.empty((count, pool_ident.shape[2]), pool_ident.dtype)
    n = 0
    for i in range(rows.shape[0]):
        if rows[i] < 0:
            continue
        for s in range(occupied.shape[1]):
            if occupied[rows[i], s]:
                state[n] = pool_state[rows[i], s]
                ident[n] = pool_ident[rows[i], s]
                n += 1
    return state, ident


def block_records(rows: np.ndarray, occupied: np.ndarray, pool_state: np.ndarray,
                  pool_ident: np.ndarray):
    """The float and integer records (N, 6), (N, 2) of the occupied slots of pool ``rows``
    (-1 skipped), in row then slot order: ``LandmarkStore.particle_map``'s, in one pass."""
    return _block_records_kernel(np.ascontiguousarray(rows), occupied, pool_state, pool_ident)


# ---------------------------------------------------------------------------- write-back
@njit(**_JIT)
def _claim_plan_kernel(table, particles, columns, refcount):
    distinct = np.zeros(table.shape[1], np.bool_)
    for i in range(columns.shape[0]):
        distinct[columns[i]] = True
    for c in range(table.shape[1]):
        if distinct[c]:
            for m in range(table.shape[0]):
                if table[m, c] >= 0:
                    refcount[table[m, c]] = 0
    for c in range(table.shape[1]):
        if distinct[c]:
            for m in range(table.shape[0]):
                if table[m, c] >= 0:
                    refcount[table[m, c]] += 1
    rows = np.empty(particles.shape[0], np.int64)
    needed = np.empty(particles.shape[0], np.bool_)
    count = 0
    for i in range(particles.shape[0]):
        rows[i] = table[particles[i], columns[i]]
        needed[i] = rows[i] < 0 or refcount[rows[i]] > 1
        count += needed[i]
    return rows, needed, count


def claim_plan(table, particles, columns, refcount):
    """``LandmarkStore._own_rows``'s first half: the references to the rows of ``columns``
    counted exactly (into ``refcount``), each pair's row, whether it needs a fresh one and
    how many do."""
    return _claim_plan_kernel(table, np.ascontiguousarray(particles, np.int64),
                              np.ascontiguousarray(columns, np.int64), refcount)


@njit(**_JIT)
def _claim_kernel(table, particles, columns, rows, needed, fresh, refcount, state, ident,
                  occupied):
    j = 0
    for i in range(particles.shape[0]):
        if not needed[i]:
            continue
        new, old = fresh[j], rows[i]
        j += 1
        if old < 0:
            for s in range(occupied.shape[1]):
                occupied[new, s] = False
        else:
            # Element by element: numba's slice copies cost more than the copy itself.
            for s in range(occupied.shape[1]):
                for e in range(STATE_WIDTH):
                    state[new, s, e] = state[old, s, e]
                ident[new, s, 0], ident[new, s, 1] = ident[old, s, 0], ident[old, s, 1]
                occupied[new, s] = occupied[old, s]
            refcount[old] -= 1
        rows[i] = new
        table[particles[i], columns[i]] = new
    return rows


def claim(table, particles, columns, rows, needed, fresh, refcount, state, ident, occupied):
    """``LandmarkStore._own_rows``'s second half: the pairs that need one take the ``fresh``
    rows in order (a copy of their shared block, or an empty one)."""
    return _claim_kernel(table, np.ascontiguousarray(particles, np.int64),
                         np.ascontiguousarray(columns, np.int64), rows, needed,
                         np.ascontiguousarray(fresh, np.int64), refcount, state, ident,
                         occupied)


@njit(**_JIT)
def _dirty_pairs_kernel(dirty, row, block, num_blocks, origin):
    num_particles, width = origin.shape[0], dirty.shape[1]
    marker = np.zeros((num_particles, num_blocks), np.bool_)
    count = 0
    for m in range(num_particles):
        o = origin[m]
        for k in range(width):
            if dirty[o, k] and row[o, k] >= 0 and not marker[m, block[o, k]]:
                marker[m, block[o, k]] = True
                count += 1
    particles = np.empty(count, np.int64)
    blocks = np.empty(count, np.int64)
    n = 0
    for m in range(num_particles):
        for b in range(num_blocks):
            if marker[m, b]:
                particles[n], blocks[n] = m, b
                n += 1
    return particles, blocks


def dirty_pairs(ws, origin):
    """The distinct (particle, gathered block) pairs holding a changed gathered entry, in
    particle then block order (``LandmarkStore._write_existing``'s); particle m's entries are
    ``ws``'s particle ``origin[m]``'s."""
    return _dirty_pairs_kernel(ws.dirty, ws.row, ws.block, ws.columns.shape[1], origin)


@njit(**_JIT)
def _write_back_kernel(dirty, row, block, slot, valid, ws_state, pair_particles, pair_blocks,
                       pair_rows, num_blocks, pool_state, occupied, origin):
    target = np.full((origin.shape[0], num_blocks), -1, np.int64)
    for i in range(pair_particles.shape[0]):
        target[pair_particles[i], pair_blocks[i]] = pair_rows[i]
    for m in range(origin.shape[0]):
        o = origin[m]
        for k in range(dirty.shape[1]):
            if dirty[o, k] and row[o, k] >= 0:
                destination = target[m, block[o, k]]
                for i in range(STATE_WIDTH):
                    pool_state[destination, slot[o, k], i] = ws_state[o, k, i]
                occupied[destination, slot[o, k]] = valid[o, k]


def write_back(ws, pair_particles, pair_blocks, pair_rows, pool_state, occupied,
               origin) -> None:
    """Every changed gathered entry into its (now private) block row and slot; particle m's
    entries are ``ws``'s particle ``origin[m]``'s."""
    _write_back_kernel(ws.dirty, ws.row, ws.block, ws.slot, ws.valid, ws.state,
                       pair_particles, pair_blocks, pair_rows, ws.columns.shape[1], pool_state,
                       occupied, origin)


@njit(**_JIT)
def _new_entries_kernel(is_new, valid, state, ident, cell_size, next_key, origin):
    count = 0
    for m in range(origin.shape[0]):
        for k in range(valid.shape[1]):
            count += is_new[origin[m], k] and valid[origin[m], k]
    owner, entry = np.empty(count, np.int64), np.empty(count, np.int64)
    ix, iy = np.empty(count, np.int64), np.empty(count, np.int64)
    keys = np.empty(count, np.int64)
    n = taken = 0
    for m in range(origin.shape[0]):
        o = origin[m]
        for k in range(valid.shape[1]):
            if not (is_new[o, k] and valid[o, k]):
                continue
            owner[n], entry[n] = m, k
            ix[n] = math.floor(state[o, k, 0] / cell_size)
            iy[n] = math.floor(state[o, k, 1] / cell_size)
            keys[n] = ident[o, k, 1]
            if keys[n] < 0:
                keys[n] = next_key + taken
                taken += 1
            n += 1
    return owner, entry, ix, iy, keys, taken


def new_entries(ws, cell_size: float, next_key: int, origin):
    """``LandmarkStore._insert_new``'s start: the new live entries (owner, entry) in particle
    then column order (particle m's entries are ``ws``'s particle ``origin[m]``'s), their
    cells (ix, iy) and keys (the keyless ones' from ``next_key`` on); and how many keys were
    taken."""
    return _new_entries_kernel(ws.is_new, ws.valid, ws.state, ws.ident, cell_size, next_key,
                               origin)


@njit(**_JIT)
def _insertion_pairs_kernel(owner, columns, pending, width):
    count = pending.shape[0]
    pair_key = np.empty(count, np.int64)
    for i in range(count):
        pair_key[i] = owner[pending[i]] * width + columns[pending[i]]
    order = np.argsort(pair_key, kind="mergesort")
    distinct = 0
    for n in range(count):
        distinct += n == 0 or pair_key[order[n]] != pair_key[order[n - 1]]
    pair_particle, pair_column = np.empty(distinct, np.int64), np.empty(distinct, np.int64)
    inverse, rank = np.empty(count, np.int64), np.empty(count, np.int64)
    pair = -1
    for n in range(count):
        i = order[n]
        if n == 0 or pair_key[i] != pair_key[order[n - 1]]:
            pair += 1
            pair_particle[pair] = pair_key[i] // width
            pair_column[pair] = pair_key[i] % width
            rank[i] = 0
        else:
            rank[i] = rank[order[n - 1]] + 1
        inverse[i] = pair
    return pair_particle, pair_column, inverse, rank


def insertion_pairs(owner, columns, pending, width: int):
    """``LandmarkStore._place_numpy``'s pairs: the distinct (particle, insertion column) pairs
    of the ``pending`` entries in increasing order, each entry's pair and its rank among the
    pair's entries (in ``pending`` order)."""
    return _insertion_pairs_kernel(owner, columns, np.ascontiguousarray(pending, np.int64),
                                   width)


@njit(**_JIT)
def _place_kernel(ws_state, ws_ident, owner, entry, keys, origin, pending, rows, inverse, rank,
                  state, ident, occupied):
    count = pending.shape[0]
    slots = np.full(count, -1, np.int64)
    for i in range(count):
        free = 0
        for s in range(occupied.shape[1]):
            if not occupied[rows[inverse[i]], s]:
                if free == rank[i]:
                    slots[i] = s
                    break
                free += 1
    fits = np.empty(count, np.bool_)
    for i in range(count):
        fits[i] = slots[i] >= 0
        if not fits[i]:
            continue
        row, slot = rows[inverse[i]], slots[i]
        o, k = origin[owner[pending[i]]], entry[pending[i]]
        occupied[row, slot] = True
        for e in range(STATE_WIDTH):
            state[row, slot, e] = ws_state[o, k, e]
        ident[row, slot, 0], ident[row, slot, 1] = ws_ident[o, k, 0], keys[pending[i]]
    return fits


def place(ws, owner, entry, keys, origin, pending, rows, inverse, rank, state, ident,
          occupied):
    """``LandmarkStore._place_numpy``'s placing: each ``pending`` entry (``new_entries``')
    with its key into the ``rank``-th free slot of its pair's (private) row
    ``rows[inverse]``; which fitted."""
    return _place_kernel(ws.state, ws.ident, owner, entry, keys, origin,
                         np.ascontiguousarray(pending, np.int64),
                         np.ascontiguousarray(rows, np.int64), inverse, rank, state, ident,
                         occupied)


# ---------------------------------------------------------------------------- warm-up
_warm = False


def warm_up() -> float:
    """Compile every kernel (or load it from the cache) on a tiny reading; seconds taken.

    The filter calls it at construction, so no reading pays for compilation; later calls
    return at once.
    """
    global _warm
    if _warm:
        return 0.0
    from .config import FastSLAMConfig  # noqa: PLC0415 (no import cycle at module load)
    from .motion import OdometryControl
    from .observation import SensorOffset
    start = time.perf_counter()
    m, width = 2, 5
    poses = np.zeros((m, 3))
    cov = np.tile(np.eye(3) * 0.01, (m, 1, 1))
    ranges, bearings = np.array([1.0, 2.0]), np.array([0.0, 0.1])
    labels = np.array([0, 1], np.int64)
    offset = SensorOffset(0.1, 0.0, 0.0)
    for mode in MODE_CODES:
        settings = reading_settings(FastSLAMConfig(association=mode), offset, -5.0, -np.inf,
                                    10.0)
        for pose_cov in (None, cov):
            state = np.zeros((m, width, 6))
            state[:, :2, 0] = [1.0, 2.0]
            state[:, :, 2] = state[:, :, 4] = 1.0
            ws = WorkingSet(row=np.full((m, width), -1, np.int64),
                            slot=np.zeros((m, width), np.int64),
                            block=np.full((m, width), -1, np.int64),
                            columns=np.zeros((m, 0), np.int64), state=state,
                            ident=np.zeros((m, width, 2), np.int64),
                            valid=np.array([[True, True, False, False, False]] * m),
                            dirty=np.zeros((m, width), bool),
                            is_new=np.zeros((m, width), bool), first_new_slot=2)
            # On the calling thread and split over threads (M >= PARALLEL_MIN_PARTICLES; its
            # chunk kernel is called by Python), with and without a pending resampling.
            for threads, order in ((1, None), (2, np.array([1, 0]))):
                _update(ws, poses, pose_cov, poses, ranges, bearings, labels,
                        np.full(2 * m, 0.5), np.zeros((m, 3)), np.zeros(m), settings, 5.0, 0,
                        pose_cov is not None, np.empty((m, 3)), order, threads)
    sample_pose(poses, cov, np.zeros((m, 3)))
    usable_observations(ranges, bearings, labels, True, 1e-3)
    pose_box(poses)
    advance_mean(None, poses, (0.1, 0.2, 0.0), settings)
    _, _, turn, motion = advance_mean((poses, cov), poses, (0.1, 0.2, 0.0), settings)
    propagate_cov(turn, None, motion)
    propagate_cov(turn, cov, motion)
    sample_motion(poses, OdometryControl(0.1, 0.2, 0.0), np.full(3, 0.01), np.zeros((m, 3)))
    indices, _, _ = resample_poses(np.full(m, 1.0 / m), np.random.default_rng(0), poses, 0)
    take(ws, indices)
    reindex(ws, indices)
    reindex(ws, indices[::-1].copy())
    prune(np.zeros(m, np.int64), np.zeros((2, m), np.int64), np.zeros((2, m, 3)),
          np.full(2, m, np.int64), 2)
    store = LandmarkStore(m, 5.0)
    for threads in (1, 2):
        _gather(store, np.zeros((m, 1), np.int64), 2, threads)
    block_records(store.table[0], store.occupied, store.state, store.ident)
    pairs = np.zeros(1, np.int64)
    rows, needed, _ = claim_plan(store.table, pairs, pairs, store.refcount)
    claim(store.table, pairs, pairs, rows, needed, np.zeros(1, np.int64), store.refcount,
          store.state, store.ident, store.occupied)
    origin = np.arange(m)
    pair_particles, pair_blocks = dirty_pairs(ws, origin)
    write_back(ws, pair_particles, pair_blocks, np.zeros(0, np.int64), store.state,
               store.occupied, origin)
    ws.is_new[:, 0] = True
    owner, entry, ix, _, keys, _ = new_entries(ws, 5.0, 0, origin)
    pending = np.arange(len(owner))
    _, pair_column, inverse, rank = insertion_pairs(owner, ix, pending, 4)
    place(ws, owner, entry, keys, origin, pending, np.zeros(len(pair_column), np.int64),
          inverse, rank, store.state, store.ident, store.occupied)
    _warm = True
    return time.perf_counter() - start


PARALLEL_MIN_PARTICLES = 500
"""Below this many particles a reading runs on the calling thread: waking a second thread
costs more than it saves, and on a busy machine far more (the reading waits for the slower
thread)."""
_max_threads = numba.config.NUMBA_NUM_THREADS


def _threads_for(num_particles: int) -> int:
    return 1 if num_particles < PARALLEL_MIN_PARTICLES else _max_threads


def splits(num_particles: int) -> bool:
    """A reading of this many particles runs on several threads."""
    return _threads_for(num_particles) > 1


def set_threads(count: int) -> None:
    """At most ``count`` threads for a reading (<= ``NUMBA_NUM_THREADS``, which defaults to
    the machine's cores)."""
    global _max_threads, _crew
    count = max(1, min(int(count), numba.config.NUMBA_NUM_THREADS))
    if count != _max_threads and _crew is not None:
        _crew.stop()
        _crew = None
    _max_threads = count
