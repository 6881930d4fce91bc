"""Compiled (numba) backend of the per-reading math of ``FastSLAM``.

The numpy core spends most of a reading at moderate M on call overhead (hundreds of small array
operations whatever M is). These kernels do the same arithmetic in one compiled loop per stage,
parallel over particles (``prange``), with the same results as the numpy functions they stand in
for: the same discrete choices and floats equal to round-off, on the same random draws (drawn by
the caller from its ``numpy.random.Generator``, exactly as the numpy path draws them).

Stages, each behind the signature of the numpy code it replaces:

* ``columns_in_reach``, ``associate_reading``: ``FastSLAM._columns_in_reach`` and the scoring and
  association rules of ``FastSLAM._associate`` (``association.score`` and the four rules);
* ``observation_proposal``, ``sample_pose`` (``proposal``) and ``propagate_gaussian`` (``motion``);
* ``apply_observations``: the landmark initialisation and Joseph-form updates of
  ``FastSLAM._apply_to_map`` (``landmark_ekf``); ``missed_evidence``: ``FastSLAM._missed_evidence``.

numba is optional (``pip install fastslam_ros[fast]``); importing this module without it raises
ImportError, and the filter then runs on numpy. ``warm_up`` compiles the kernels (or loads them
from numba's cache) so that compilation never lands on the first reading. The cache lives beside
this file when its folder is writable and in numba's user cache folder otherwise
(``NUMBA_CACHE_DIR`` overrides both), so a read-only install works.
"""
from __future__ import annotations

import math
import os
import time

import numpy as np
import numba
from numba import njit, prange

LOG_TWO_PI = math.log(2.0 * math.pi)
TWO_PI = 2.0 * math.pi
POSE_JITTER = 1e-12

MODE_CODES = {"known": 0, "ml": 1, "monte_carlo": 2, "two_gate": 3}
NEW, IGNORE = -1, -2

if "NUMBA_THREADING_LAYER" not in os.environ:
    # Threads that sleep while they wait: OpenMP's spinning threads stall every reading when
    # the other cores are busy (measured 5x slower at M = 1,000 on a shared 2-core machine).
    numba.config.THREADING_LAYER = "workqueue"

_JIT = dict(cache=True, nogil=True, error_model="numpy")
_PARALLEL = dict(_JIT, parallel=True)

# Cofactor C_ij = a[p] a[q] - a[r] a[s] of a row-major 3x3 matrix (as in ``proposal``).
_COF_P = np.array([4, 5, 3, 2, 0, 1, 1, 2, 0])
_COF_Q = np.array([8, 6, 7, 7, 8, 6, 5, 3, 4])
_COF_R = np.array([5, 3, 4, 1, 2, 0, 2, 0, 1])
_COF_S = np.array([7, 8, 6, 8, 6, 7, 4, 5, 3])


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


# ---------------------------------------------------------------------------- association
@njit(**_PARALLEL)
def _reach_kernel(state, valid, existing, poses, reach):
    width = existing
    near = np.zeros(width, np.bool_)
    count = poses.shape[0]
    limit = reach * reach
    for j in prange(width):
        for m in range(count):
            if valid[m, j]:
                dx = state[m, j, 0] - poses[m, 0]
                dy = state[m, j, 1] - poses[m, 1]
                if dx * dx + dy * dy <= limit:
                    near[j] = True
                    break
    return near


def columns_in_reach(ws, poses: np.ndarray, reach: float) -> np.ndarray:
    """Working-set columns (before ``first_new_slot``) holding a landmark of some particle
    within ``reach`` of that particle's pose, ascending."""
    near = _reach_kernel(ws.state, ws.valid, ws.first_new_slot, np.ascontiguousarray(poses),
                         float(reach))
    return near.nonzero()[0]


@njit(**_JIT)
def _score_pair(m, j, state, mean, cov, has_cov, ox, oy, oyaw, ranges, bearings, noise_r,
                noise_b, log_lik, mahalanobis, column):
    """log N and Mahalanobis distance of every observation against landmark j of particle m
    (``association.score``), into column ``column`` of the (K, C) buffers."""
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
    cxy = cxy0 + extra_xy
    cyy = cyy0 + extra_yy
    last_noise = np.nan
    inv_xx = inv_xy2 = inv_yy = log_norm = 0.0
    for k in range(ranges.shape[0]):
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
def _score_one(m, j, k, state, mean, cov, has_cov, ox, oy, oyaw, ranges, bearings, noise_r,
               noise_b):
    """log N of observation k against landmark j of particle m (known ids)."""
    buffer_lik = np.empty((1, 1))
    buffer_mah = np.empty((1, 1))
    _score_pair(m, j, state, mean, cov, has_cov, ox, oy, oyaw, ranges[k:k + 1],
                bearings[k:k + 1], noise_r[k:k + 1], noise_b, buffer_lik, buffer_mah, 0)
    return buffer_lik[0, 0]


@njit(**_JIT)
def _argmax_first(row):
    """numpy's argmax: the first maximum (0 when all are -inf)."""
    best, value = 0, row[0]
    for c in range(1, row.shape[0]):
        if row[c] > value:
            best, value = c, row[c]
    return best, value


@njit(**_JIT)
def _exclusive_ml(log_lik, log_p0, choice, factor, m):
    """``association.associate_exclusive_maximum_likelihood`` for one particle."""
    count, width = log_lik.shape
    pick = np.empty(count, np.int64)
    value = np.empty(count)
    while True:
        for k in range(count):
            if width == 0:
                pick[k], value[k] = NEW, log_p0
                continue
            best, best_value = _argmax_first(log_lik[k])
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
def _monte_carlo(log_lik, log_p0, draws, choice, factor, inverse_q, m, num_particles):
    """``association.associate_monte_carlo`` (marginal weight) for one particle."""
    count, width = log_lik.shape
    order = np.empty(width, np.int64)
    cumulative = np.empty(width + 1)
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
            inverse_q[k, m] = log_marginal - row[chosen]


@njit(**_JIT)
def _two_gates(log_lik, mahalanobis, log_p0, gate, new_gate, choice, factor, m):
    """``association.associate_two_gates`` for one particle."""
    count, width = log_lik.shape
    for k in range(count):
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


@njit(**_PARALLEL)
def _associate_kernel(state, valid, label, existing, kept, reach, mean, cov, has_cov, ranges,
                      bearings, labels, noise_r, noise_b, ox, oy, oyaw, mode, log_p0, gate,
                      new_gate, draws, score_known):
    count = ranges.shape[0]
    num_particles = mean.shape[0]
    choice = np.empty((count, num_particles), np.int64)
    factor = np.empty((count, num_particles))
    inverse_q = np.zeros((count, num_particles))
    width = kept.shape[0]
    limit = reach * reach
    for m in prange(num_particles):
        if mode == 0:
            for k in range(count):
                candidate = -1
                for j in range(existing):
                    if valid[m, j] and label[m, j] == labels[k]:
                        candidate = j
                        break
                choice[k, m] = candidate
                if candidate < 0:
                    factor[k, m] = log_p0
                elif score_known:
                    factor[k, m] = _score_one(m, candidate, k, state, mean, cov, has_cov, ox,
                                              oy, oyaw, ranges, bearings, noise_r, noise_b)
                else:
                    factor[k, m] = 0.0
            continue
        # This particle's candidates, in column order: the rules see the same choices as on
        # the full row with -inf / +inf for the others, which can never be picked.
        local = np.empty(width, np.int64)
        found = 0
        for c in range(width):
            j = kept[c]
            dx = state[m, j, 0] - mean[m, 0]
            dy = state[m, j, 1] - mean[m, 1]
            if valid[m, j] and dx * dx + dy * dy <= limit:
                local[found] = j
                found += 1
        log_lik = np.empty((count, found))
        mahalanobis = np.empty((count, found))
        for c in range(found):
            _score_pair(m, local[c], state, mean, cov, has_cov, ox, oy, oyaw, ranges, bearings,
                        noise_r, noise_b, log_lik, mahalanobis, c)
        if mode == 1:
            _exclusive_ml(log_lik, log_p0, choice, factor, m)
        elif mode == 2:
            _monte_carlo(log_lik, log_p0, draws, choice, factor, inverse_q, m, num_particles)
        else:
            _two_gates(log_lik, mahalanobis, log_p0, gate, new_gate, choice, factor, m)
        for k in range(count):
            if choice[k, m] >= 0:
                choice[k, m] = local[choice[k, m]]
    return choice, factor, inverse_q


def associate_reading(ws, kept, reach: float, mean, cov, ranges, bearings, labels, noise,
                      offset, mode: str, log_p0: float, gate: float, new_gate: float, draws,
                      score_known: bool):
    """Choices (K, M) (working-set columns or ``NEW`` / ``IGNORE``), log factors (K, M) and
    log(1 / q) (K, M) of one reading, as ``FastSLAM._associate`` forms them before the outlier
    test. ``kept``: the candidate columns (``columns_in_reach``; unused with known ids), of
    which a particle scores those within ``reach`` of its pose;
    ``draws``: the (K * M) uniforms of ``monte_carlo``; ``score_known``: known ids score their
    landmark (otherwise the factor is 0, FastSLAM 2.0 weighing by the proposal)."""
    noise_r, noise_b = _noise_arrays(noise, len(ranges))
    has_cov = cov is not None
    return _associate_kernel(
        ws.state, ws.valid, ws.label, ws.first_new_slot, np.asarray(kept, np.int64),
        float(reach), np.ascontiguousarray(mean),
        np.ascontiguousarray(cov) if has_cov else _NO_COV, has_cov,
        ranges, bearings, labels, noise_r, noise_b, offset.x, offset.y, offset.yaw,
        MODE_CODES[mode], log_p0, gate, new_gate, draws, score_known)


_NO_COV = np.zeros((1, 3, 3))
_NO_DRAWS = np.zeros(0)


def _noise_arrays(noise, count: int) -> tuple[np.ndarray, float]:
    """(range variance per observation (K,), bearing variance) from ``FastSLAM._noise``."""
    range_variance, bearing_variance = noise[0], float(noise[1])
    if isinstance(range_variance, np.ndarray) and range_variance.size == count:
        return np.ascontiguousarray(range_variance, dtype=float).reshape(count), bearing_variance
    return np.full(count, float(range_variance)), bearing_variance


# ---------------------------------------------------------------------------- proposal
@njit(**_PARALLEL)
def _records_kernel(state, columns):
    count, num_particles = columns.shape
    out = np.empty((count, num_particles, state.shape[2]))
    for m in prange(num_particles):
        for k in range(count):
            column = max(columns[k, m], 0)
            for i in range(state.shape[2]):
                out[k, m, i] = state[m, column, i]
    return out


def records_at(ws, columns: np.ndarray) -> np.ndarray:
    """``WorkingSet.records_at`` for (K, M) columns."""
    return _records_kernel(ws.state, np.ascontiguousarray(columns, dtype=np.int64))



@njit(**_PARALLEL)
def _proposal_kernel(mean, cov, landmarks, ranges, bearings, used, ox, oy, oyaw, noise_r,
                     noise_b):
    count, num_particles = used.shape
    point = np.empty((num_particles, 3))
    sigma = np.empty((num_particles, 3, 3))
    log_weight = np.empty(num_particles)
    for m in prange(num_particles):
        px, py, pth = mean[m, 0], mean[m, 1], mean[m, 2]
        lx, ly = _lever(pth, ox, oy)
        lever_free = lx == 0.0 and ly == 0.0 and ox == 0.0 and oy == 0.0
        info = np.zeros((3, 3))
        b = np.zeros(3)
        quadratic = 0.0
        log_det_q = 0.0
        pairs = 0
        g = np.empty((2, 3))
        u = np.empty((2, 3))
        for k in range(count):
            if not used[k, m]:
                continue
            pairs += 1
            dx = landmarks[k, m, 0] - (px + lx)
            dy = landmarks[k, m, 1] - (py + ly)
            q = dx * dx + dy * dy
            r = math.sqrt(q)
            sxx, sxy, syy = landmarks[k, m, 2], landmarks[k, m, 3], landmarks[k, m, 4]
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
            g[0, 0], g[0, 1], g[0, 2] = -g00, -g01, w0
            g[1, 0], g[1, 1], g[1, 2] = -g10, -g11, w1
            nu0 = ranges[k] - r
            nu1 = _wrap(bearings[k] + (pth + oyaw) - math.atan2(dy, dx))
            det = q00 * q11 - q01 * q01
            scale = 1.0 / det
            i00, i01, i11 = q11 * scale, -q01 * scale, q00 * scale
            for col in range(3):
                u[0, col] = i00 * g[0, col] + i01 * g[1, col]
                u[1, col] = i01 * g[0, col] + i11 * g[1, col]
            for row in range(3):
                for col in range(3):
                    info[row, col] += g[0, row] * u[0, col] + g[1, row] * u[1, col]
                b[row] += u[0, row] * nu0 + u[1, row] * nu1
            quadratic += nu0 * (i00 * nu0 + i01 * nu1) + nu1 * (i01 * nu0 + i11 * nu1)
            log_det_q += math.log(det)
        # Sigma_s = (I + P J)^-1 P through the adjugate (``proposal._combine``).
        a = np.empty(9)
        for row in range(3):
            for col in range(3):
                a[3 * row + col] = (cov[m, row, 0] * info[0, col] + cov[m, row, 1] * info[1, col]
                                    + cov[m, row, 2] * info[2, col])
        a[0] += 1.0
        a[4] += 1.0
        a[8] += 1.0
        cof = np.empty(9)
        for i in range(9):
            cof[i] = a[_COF_P[i]] * a[_COF_Q[i]] - a[_COF_R[i]] * a[_COF_S[i]]
        det_a = a[0] * cof[0] + a[1] * cof[1] + a[2] * cof[2]
        full = np.empty((3, 3))
        for row in range(3):
            for col in range(3):
                full[row, col] = (cof[row] * cov[m, 0, col] + cof[3 + row] * cov[m, 1, col]
                                  + cof[6 + row] * cov[m, 2, col]) / det_a
        for row in range(3):
            for col in range(3):
                sigma[m, row, col] = 0.5 * (full[row, col] + full[col, row])
        mahalanobis = quadratic
        for row in range(3):
            shift = sigma[m, row, 0] * b[0] + sigma[m, row, 1] * b[1] + sigma[m, row, 2] * b[2]
            mahalanobis -= b[row] * shift
            point[m, row] = mean[m, row] + shift
        point[m, 2] = _wrap(point[m, 2])
        log_weight[m] = (-0.5 * (mahalanobis + log_det_q + math.log(det_a))
                         - pairs * LOG_TWO_PI)
    return point, sigma, log_weight


def observation_proposal(mean: np.ndarray, cov: np.ndarray, landmarks: np.ndarray,
                         ranges: np.ndarray, bearings: np.ndarray, used: np.ndarray,
                         offset, noise_diag, iterations: int = 1):
    """``proposal.observation_proposal`` for one reading (``ranges`` and ``bearings`` (K, 1)),
    linearised once (``iterations`` 1)."""
    if iterations != 1:
        raise ValueError("the compiled proposal is linearised once (iterations 1)")
    count = used.shape[0]
    noise_r, noise_b = _noise_arrays(noise_diag, count)
    return _proposal_kernel(np.ascontiguousarray(mean), np.ascontiguousarray(cov),
                            np.ascontiguousarray(landmarks),
                            np.ascontiguousarray(ranges, dtype=float).reshape(count),
                            np.ascontiguousarray(bearings, dtype=float).reshape(count),
                            np.ascontiguousarray(used), offset.x, offset.y, offset.yaw,
                            noise_r, noise_b)


@njit(**_PARALLEL)
def _sample_pose_kernel(mean, cov, normals):
    count = mean.shape[0]
    out = np.empty((count, 3))
    for m in prange(count):
        c00, c01, c02 = cov[m, 0, 0], cov[m, 0, 1], cov[m, 0, 2]
        c11, c12, c22 = cov[m, 1, 1], cov[m, 1, 2], cov[m, 2, 2]
        l00 = math.sqrt(max(c00, 0.0) + POSE_JITTER)
        l10, l20 = c01 / l00, c02 / l00
        l11 = math.sqrt(max(c11 - l10 * l10, 0.0) + POSE_JITTER)
        l21 = (c12 - l20 * l10) / l11
        l22 = math.sqrt(max(c22 - l20 * l20 - l21 * l21, 0.0) + POSE_JITTER)
        n0, n1, n2 = normals[m, 0], normals[m, 1], normals[m, 2]
        out[m, 0] = mean[m, 0] + l00 * n0
        out[m, 1] = mean[m, 1] + (l10 * n0 + l11 * n1)
        out[m, 2] = mean[m, 2] + (l20 * n0 + l21 * n1 + l22 * n2)
    return out


def sample_pose(mean: np.ndarray, cov: np.ndarray, standard_normals: np.ndarray) -> np.ndarray:
    """``proposal.sample_pose``."""
    return _sample_pose_kernel(np.ascontiguousarray(mean), np.ascontiguousarray(cov),
                               np.ascontiguousarray(standard_normals))


@njit(**_PARALLEL)
def _propagate_kernel(mean, cov, rot1, trans, rot2, v_rot1, v_trans, v_rot2):
    count = mean.shape[0]
    moved = np.empty((count, 3))
    predicted = np.empty((count, 3, 3))
    for m in prange(count):
        heading = mean[m, 2] + rot1
        cos_h, sin_h = math.cos(heading), math.sin(heading)
        fx, fy = -trans * sin_h, trans * cos_h
        c0, c1, c2 = cov[m, 0, 2], cov[m, 1, 2], cov[m, 2, 2]
        w = c2 + v_rot1
        xx = cov[m, 0, 0] + 2.0 * fx * c0 + w * fx * fx + v_trans * cos_h * cos_h
        xy = cov[m, 0, 1] + fx * c1 + fy * c0 + w * fx * fy + v_trans * cos_h * sin_h
        yy = cov[m, 1, 1] + 2.0 * fy * c1 + w * fy * fy + v_trans * sin_h * sin_h
        xt, yt, tt = c0 + w * fx, c1 + w * fy, c2 + (v_rot1 + v_rot2)
        predicted[m, 0, 0], predicted[m, 0, 1], predicted[m, 0, 2] = xx, xy, xt
        predicted[m, 1, 0], predicted[m, 1, 1], predicted[m, 1, 2] = xy, yy, yt
        predicted[m, 2, 0], predicted[m, 2, 1], predicted[m, 2, 2] = xt, yt, tt
        moved[m, 0] = mean[m, 0] + trans * cos_h
        moved[m, 1] = mean[m, 1] + trans * sin_h
        moved[m, 2] = _wrap(heading + rot2)
    return moved, predicted


def propagate_gaussian(mean: np.ndarray, cov: np.ndarray, u, variances: np.ndarray):
    """``motion.propagate_gaussian``."""
    v_rot1, v_trans, v_rot2 = (float(v) for v in variances)
    return _propagate_kernel(np.ascontiguousarray(mean), np.ascontiguousarray(cov),
                             float(u.rot1), float(u.trans), float(u.rot2), v_rot1, v_trans,
                             v_rot2)


# ---------------------------------------------------------------------------- map
@njit(**_PARALLEL)
def _apply_kernel(state, ident, valid, dirty, is_new, observed, choices, creating, column,
                  keys, poses, ranges, bearings, labels, noise_r, noise_b, ox, oy, oyaw,
                  logodds_observed, logodds_max):
    count, num_particles = choices.shape
    for m in prange(num_particles):
        px, py, pth = poses[m, 0], poses[m, 1], poses[m, 2]
        lx, ly = _lever(pth, ox, oy)
        heading = pth + oyaw
        for k in range(count):
            if not creating[k, m]:
                continue
            slot = column[k]
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
            state[m, slot, 0], state[m, slot, 1] = mx, my
            state[m, slot, 2] = inv00 * inv00 * r0 + inv01 * inv01 * noise_b
            state[m, slot, 3] = inv00 * inv10 * r0 + inv01 * inv11 * noise_b
            state[m, slot, 4] = inv10 * inv10 * r0 + inv11 * inv11 * noise_b
            state[m, slot, 5] = logodds_observed
            ident[m, slot, 0] = labels[k]
            ident[m, slot, 1] = keys[k, m]
            valid[m, slot] = True
            is_new[m, slot] = True
            observed[m, slot] = True
            choices[k, m] = slot
        for k in range(count):
            slot = choices[k, m]
            if slot < 0 or creating[k, m]:
                continue
            # Joseph-form EKF update (``update_landmarks``), observations in turn.
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
            state[m, slot, 5] = min(state[m, slot, 5] + logodds_observed, logodds_max)
            dirty[m, slot] = True
            observed[m, slot] = True


def apply_observations(ws, observed, choices, creating, column, first_key: int, poses, ranges,
                       bearings, labels, noise, offset, logodds_observed: float,
                       logodds_max: float) -> None:
    """The map part of ``FastSLAM._apply_to_map`` once the new landmarks' columns are known:
    creating pairs (K, M) initialise the landmark in ``column[k]`` (keys from ``first_key`` in
    observation-major order) and get it as their choice; the other associated pairs update
    their landmark, a particle's observations in turn."""
    noise_r, noise_b = _noise_arrays(noise, len(ranges))
    keys = (first_key - 1 + np.cumsum(creating.ravel())).reshape(creating.shape)
    _apply_kernel(ws.state, ws.ident, ws.valid, ws.dirty, ws.is_new, observed, choices,
                  np.ascontiguousarray(creating), np.asarray(column, np.int64), keys,
                  np.ascontiguousarray(poses), ranges, bearings, labels, noise_r, noise_b,
                  offset.x, offset.y, offset.yaw, logodds_observed, logodds_max)


@njit(**_PARALLEL)
def _missed_kernel(state, valid, dirty, observed, existing, poses, ox, oy, oyaw, min_range,
                   max_range, field_of_view, logodds_missed, logodds_remove):
    num_particles = poses.shape[0]
    limited = field_of_view < TWO_PI
    cos_half = math.cos(0.5 * field_of_view)
    for m in prange(num_particles):
        px, py, pth = poses[m, 0], poses[m, 1], poses[m, 2]
        lx, ly = _lever(pth, ox, oy)
        heading = pth + oyaw
        cos_h, sin_h = math.cos(heading), math.sin(heading)
        for j in range(existing):
            if not valid[m, j] or observed[m, j]:
                continue
            dx = state[m, j, 0] - (px + lx)
            dy = state[m, j, 1] - (py + ly)
            r = math.sqrt(dx * dx + dy * dy)
            if r < min_range or r > max_range:
                continue
            if limited and dx * cos_h + dy * sin_h < r * cos_half:
                continue
            state[m, j, 5] += logodds_missed
            dirty[m, j] = True
            if state[m, j, 5] < logodds_remove:
                valid[m, j] = False


def missed_evidence(ws, observed, poses, offset, config) -> None:
    """``FastSLAM._missed_evidence``: lower the log-odds of the unobserved landmarks in the
    perceptual range, removing those below ``logodds_remove``."""
    _missed_kernel(ws.state, ws.valid, ws.dirty, observed, ws.first_new_slot,
                   np.ascontiguousarray(poses), offset.x, offset.y, offset.yaw,
                   config.min_range, config.max_range, config.field_of_view,
                   config.logodds_missed, config.logodds_remove)


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
    from .landmark_store import WorkingSet  # noqa: PLC0415 (no import cycle at module load)
    from .motion import OdometryControl
    from .observation import SensorOffset
    start = time.perf_counter()
    m, k, width = 2, 2, 3
    state = np.zeros((m, width, 6))
    state[:, :, 0] = [[1.0, 2.0, 0.0], [1.0, 2.0, 0.0]]
    state[:, :, 2] = state[:, :, 4] = 1.0
    ws = WorkingSet(row=np.full((m, width), -1, np.int64), slot=np.zeros((m, width), np.int64),
                    block=np.full((m, width), -1, np.int64), columns=np.zeros((m, 0), np.int64),
                    state=state, ident=np.zeros((m, width, 2), np.int64),
                    valid=np.array([[True, True, False]] * m), dirty=np.zeros((m, width), bool),
                    is_new=np.zeros((m, width), bool), first_new_slot=2)
    poses = np.zeros((m, 3))
    cov = np.tile(np.eye(3) * 0.01, (m, 1, 1))
    ranges, bearings = np.array([1.0, 2.0]), np.array([0.0, 0.1])
    labels = np.array([0, 1], np.int64)
    offset = SensorOffset(0.1, 0.0, 0.0)
    noise = (0.01, 0.001)
    kept = columns_in_reach(ws, poses, 5.0)
    for mode in MODE_CODES:
        for pose_cov in (None, cov):
            associate_reading(ws, kept, 5.0, poses, pose_cov, ranges, bearings, labels, noise,
                              offset, mode, -5.0, 9.0, 25.0, np.full(k * m, 0.5), True)
    used = np.ones((k, m), bool)
    records = records_at(ws, np.zeros((k, m), np.int64))
    mean, sigma, _ = observation_proposal(poses, cov, records, ranges[:, None],
                                          bearings[:, None], used, offset, noise)
    sample_pose(mean, sigma, np.zeros((m, 3)))
    propagate_gaussian(poses, cov, OdometryControl(0.1, 0.2, 0.0), np.full(3, 0.01))
    observed = np.zeros((m, width), bool)
    choices = np.array([[0, 0], [NEW, NEW]], np.int64)
    creating = choices == NEW
    apply_observations(ws, observed, choices, creating, np.array([-1, 2], np.int64), 0, poses,
                       ranges, bearings, labels, noise, offset, 1.0, 10.0)
    missed_evidence(ws, observed, poses, offset, _WarmConfig)
    _warm = True
    return time.perf_counter() - start


class _WarmConfig:
    min_range, max_range, field_of_view = 0.0, 10.0, 3.0
    logodds_missed, logodds_remove = -0.5, -1.5


PARALLEL_MIN_PARTICLES = 500
"""Below this many particles the kernels run on the calling thread: waking a second thread
costs more than it saves, and on a busy machine far more (the reading waits for the slower
thread)."""
_max_threads = numba.config.NUMBA_NUM_THREADS


def use_threads(num_particles: int) -> None:
    """Threads for the next kernels of a filter with ``num_particles`` (on this thread)."""
    numba.set_num_threads(1 if num_particles < PARALLEL_MIN_PARTICLES else _max_threads)


def set_threads(count: int) -> None:
    """At most ``count`` threads in the parallel kernels (<= ``NUMBA_NUM_THREADS``, which
    defaults to the machine's cores)."""
    global _max_threads
    _max_threads = max(1, min(int(count), numba.config.NUMBA_NUM_THREADS))
