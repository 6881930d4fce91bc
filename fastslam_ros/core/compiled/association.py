# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""numba twin of ``core/association.py``: candidates in reach, the pair scores and the four
association rules (known, maximum likelihood, Monte Carlo, two gates) for one particle, and
the outlier test; the same choices as the numpy module on the same draws."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..association import IGNORE, NEW
from ..geometry import LOG_TWO_PI
from .jit import _INLINED, _JIT, _lever, _logaddexp, _wrap


@njit(**_JIT)
def _score_pair(m, j, k_lo, k_hi, column, state, particles, has_cov, settings, obs, work):
    """log N and Mahalanobis distance of observations [k_lo, k_hi) against landmark j of
    particle m (``association.score``), into column ``column`` of the (K, C) buffers of
    ``work`` (``Scratch``); the pair's (dx, dy, q, r, predicted bearing) into
    ``work.terms[column]`` (the proposal reuses them)."""
    ox, oy, oyaw = settings.sensor_x, settings.sensor_y, settings.sensor_yaw
    noise_b = settings.bearing_variance
    mean, cov = particles.mean, particles.cov
    ranges, bearings, noise_r = obs.ranges, obs.bearings, obs.range_variance
    log_lik, mahalanobis, terms = work.log_lik, work.mahalanobis, work.terms
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


@njit(**_INLINED)
def _associate_particle(m, table, particles, obs, uniforms, settings, plan, out, work):
    """``FastSLAM._associate`` for particle m before the outlier test: its choices (working-set
    columns or ``NEW`` / ``IGNORE``) and log factors into column m of ``out.choice`` and
    ``out.factor``, log(1 / q) of its associations into ``work.inverse_q`` (K,);
    ``work.picked[k]``: the row of ``work.terms`` of the chosen candidate (but with known
    ids)."""
    count = obs.ranges.shape[0]
    state, valid, ident = table.state, table.valid, table.ident
    choice, factor = out.choice, out.factor
    existing, has_cov = plan.existing, plan.has_cov
    log_p0 = settings.log_p0
    for k in range(count):
        work.inverse_q[k] = 0.0
    mode = settings.association
    if mode == 0:
        for k in range(count):
            candidate = -1
            for j in range(existing):
                if valid[m, j] and ident[m, j, 0] == obs.labels[k]:
                    candidate = j
                    break
            choice[k, m] = candidate
            if candidate < 0:
                factor[k, m] = log_p0
            elif plan.score_known:
                _score_pair(m, candidate, k, k + 1, 0, state, particles, has_cov, settings, obs,
                            work)
                factor[k, m] = work.log_lik[k, 0]
            else:
                factor[k, m] = 0.0
        return
    # This particle's candidates within reach, in column order: the rules see the same
    # choices as on the numpy path's full row, where the others are -inf / +inf.
    mean, local = particles.mean, work.local
    limit = plan.reach * plan.reach
    found = 0
    for j in range(existing):
        if valid[m, j]:
            dx = state[m, j, 0] - mean[m, 0]
            dy = state[m, j, 1] - mean[m, 1]
            if dx * dx + dy * dy <= limit:
                local[found] = j
                found += 1
    for c in range(found):
        _score_pair(m, local[c], 0, count, c, state, particles, has_cov, settings, obs, work)
    if mode == 1:
        _exclusive_ml(work.log_lik, found, log_p0, choice, factor, m, work.pick, work.value)
    elif mode == 2:
        _monte_carlo(work.log_lik, found, log_p0, uniforms, choice, factor, work.inverse_q, m,
                     work.order, work.cumulative)
    else:
        _two_gates(work.log_lik, work.mahalanobis, found, log_p0, settings.association_gate,
                   settings.new_landmark_gate, choice, factor, m)
    for k in range(count):
        work.picked[k] = choice[k, m]
        if choice[k, m] >= 0:
            choice[k, m] = local[choice[k, m]]


@njit(**_JIT)
def _reject_outliers(m, choice, factor, robust, settings):
    """``association.reject_outliers`` for particle m: outliers become ``IGNORE`` with the
    robust factor; ``robust`` (K,) gets the inliers' correction."""
    eps, log_outlier = settings.outlier_probability, settings.log_outlier
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
