# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The compiled reading: one call (``update_reading``) runs a whole reading for every particle
(association, proposal, weight, map) in ``_reading_chunk``, then the short serial pass
(``_settle``: new landmarks' columns and keys, weight normalisation, the report); on the
calling thread, or split over the crew's threads from ``crew.PARALLEL_MIN_PARTICLES``."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from . import crew
from ..association import IGNORE, NEW
from ..landmark_store import STATE_WIDTH, WorkingSet
from .association import _associate_particle, _reject_outliers
from .crew import _claim, _run_shared, READING_BLOCK
from .jit import _JIT, _wrap
from .landmark_ekf import _map_particle, _place_new
from .motion import _NO_COV, _propagate_cov
from .proposal import _propose_and_draw
from .settings import (F_EPS, F_MOTION, F_NOISE_R, F_NOISE_R_PER_M, F_REACH, I_CENTRAL, I_FIRST_KEY,
                       I_HAS_COV, I_LOCALIZATION, I_MODE, I_MOTION, I_PRIOR_COV, I_PROPOSE,
                       I_SCORE_KNOWN, ReadingSettings)


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
                   crew.threads_for(poses.shape[0]), motion)


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
