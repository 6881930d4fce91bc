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
from .jit import _INLINED, _JIT, _wrap
from .landmark_ekf import _map_particle, _place_new
from .motion import _NO_COV, _propagate_cov
from .proposal import _propose_and_draw
from .records import (DeferredMotion, Draws, Entries, NewLandmarks, Observations, Particles,
                      PendingResampling, ReadingOutputs, entries_of, scratch)
from .settings import ReadingPlan, ReadingSettings, reading_plan


@njit(**_INLINED)
def _clear_entry(table, m, j):
    """Entry (m, j) of ``table`` (``Entries``) empty, as a gathered working set leaves its
    free columns (a unit covariance, so that scoring it stays finite)."""
    for i in range(STATE_WIDTH):
        table.state[m, j, i] = 0.0
    table.state[m, j, 2] = table.state[m, j, 4] = 1.0
    table.ident[m, j, 0] = table.ident[m, j, 1] = -1
    table.row[m, j], table.slot[m, j], table.block[m, j] = -1, 0, -1
    table.valid[m, j] = table.dirty[m, j] = table.is_new[m, j] = False


@njit(**_JIT)
def _copy_entries(source, origin, table, m, count):
    """Particle m's entries of the first ``count`` columns of ``table`` become particle
    ``origin``'s of ``source`` (both ``Entries``)."""
    for j in range(count):
        table.row[m, j] = source.row[origin, j]
        table.slot[m, j] = source.slot[origin, j]
        table.block[m, j] = source.block[origin, j]
        for i in range(STATE_WIDTH):
            table.state[m, j, i] = source.state[origin, j, i]
        table.ident[m, j, 0] = source.ident[origin, j, 0]
        table.ident[m, j, 1] = source.ident[origin, j, 1]
        table.valid[m, j], table.dirty[m, j] = source.valid[origin, j], source.dirty[origin, j]
        table.is_new[m, j] = source.is_new[origin, j]


@njit(**_INLINED)
def _take_particle(m, origin, existing, source, table):
    """Particle m's working-set entries become particle ``origin``'s of ``source``
    (``WorkingSet.take``). The columns from ``existing`` on are empty in every particle (new
    landmarks fill them in order, and ``first_new_slot`` follows), so they are written empty,
    not copied."""
    _copy_entries(source, origin, table, m, existing)
    for j in range(existing, table.valid.shape[1]):
        _clear_entry(table, m, j)


@njit(**_JIT)
def _reading_chunk(counter, block, table, pending, particles, motion, obs, draws, settings,
                   plan, out):
    """Blocks of ``block`` particles taken from ``counter`` (``_claim``) until none is left,
    each particle in turn: its working-set entries (``table``) taken from ``pending`` (a
    resampling since the last reading), with ``plan.propagate`` its prior covariance
    ``particles.cov[m]`` propagated by ``motion`` (``advance_mean``), then association,
    outlier test, (FastSLAM 2.0) proposal and draw, the new log weight (before
    normalisation) and its map (``_map_particle``, the new landmarks left to ``_place_new``),
    all into ``out`` (``ReadingOutputs``); ``out.finite[m]`` False for a non-finite update;
    the new pose also into ``out.recorded[m]`` (the path history's next generation);
    ``counter[1]`` counts the particles finished (``_Crew.run`` waits for it). Called from
    Python (``_reading_threaded``), it takes its records as plain tuples (``records``)."""
    table, particles, obs, draws = (Entries(*table), Particles(*particles),
                                    Observations(*obs), Draws(*draws))
    pending = PendingResampling(pending[0], Entries(*pending[1]))
    motion, settings = DeferredMotion(*motion), ReadingSettings(*settings)
    plan, out = ReadingPlan(*plan), ReadingOutputs(*out)
    count = obs.ranges.shape[0]
    existing = plan.existing
    work = scratch(count, max(existing, 1))
    choice, factor, poses_out = out.choice, out.factor, out.poses
    scored = settings.association != 0
    localization = settings.localization
    ordered = pending.order.shape[0] > 0
    poses = particles.poses
    num_particles = poses.shape[0]
    motion_terms = motion.terms
    while True:
        lo = _claim(counter, 0, block)
        if lo >= num_particles:
            return
        hi = min(lo + block, num_particles)
        for m in range(lo, hi):
            if ordered:
                _take_particle(m, pending.order[m], existing, pending.source, table)
            if plan.propagate:
                _propagate_cov(m, motion.turn, motion.cov, plan.prior_has_cov, motion_terms[1],
                               motion_terms[3], motion_terms[4], motion_terms[5], particles.cov)
            _associate_particle(m, table, particles, obs, draws.uniforms, settings, plan, out,
                                work)
            _reject_outliers(m, choice, factor, work.robust, settings)
            if localization:
                # A fixed map takes no new landmark: an unexplained observation weighs p0.
                for k in range(count):
                    if choice[k, m] == NEW:
                        choice[k, m] = IGNORE
            if plan.propose:
                joint = _propose_and_draw(m, table.state, particles, obs, choice, settings,
                                          draws.normals, poses_out, work, scored)
                # The associated observations weigh their joint likelihood (on the first row)
                # times 1 / q (``FastSLAM._sample_proposal``).
                for k in range(count):
                    if choice[k, m] >= 0:
                        factor[k, m] = work.inverse_q[k]
                if count:
                    factor[0, m] += joint
            else:
                poses_out[m, 0], poses_out[m, 1], poses_out[m, 2] = (
                    poses[m, 0], poses[m, 1], poses[m, 2])
            total = 0.0
            for k in range(count):
                factor[k, m] = factor[k, m] + work.robust[k]
                total += factor[k, m]
            out.log_weights[m] = particles.log_weights[m] + total
            out.finite[m] = localization or _map_particle(m, table, existing, choice, poses_out,
                                                          obs, settings, work.observed,
                                                          out.fresh)
            out.recorded[m, 0], out.recorded[m, 1], out.recorded[m, 2] = (
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
def _range_variances(ranges, settings):
    """Range variance of every observation (``FastSLAM._noise``)."""
    noise_r = np.empty(ranges.shape[0])
    per_meter = settings.sigma_range_per_meter
    for k in range(ranges.shape[0]):
        noise_r[k] = settings.range_variance
        if per_meter != 0.0:
            noise_r[k] = settings.range_variance + (per_meter * ranges[k]) ** 2
    return noise_r


@njit(**_JIT)
def _reading_buffers(ranges, bearings, labels, num_particles, settings, recorded):
    """The reading's ``Observations`` (with their range variances and the observation whose
    landmark each one creates: itself; with known ids the first of its id) and the
    ``ReadingOutputs`` the chunks write (the new poses also into ``recorded``), as plain
    tuples (``records``; so are the ``settings`` it takes)."""
    settings = ReadingSettings(*settings)
    count = ranges.shape[0]
    creator = np.arange(count)
    if settings.association == 0:
        for k in range(count):
            for other in range(k):
                if labels[other] == labels[k]:
                    creator[k] = other
                    break
    obs = (ranges, bearings, labels, _range_variances(ranges, settings), creator)
    out = (np.empty((count, num_particles), np.int64), np.empty((count, num_particles)),
           np.empty((num_particles, 3)), np.empty(num_particles),
           np.empty((count, num_particles, 5)), np.ones(num_particles, np.bool_), recorded)
    return obs, out


@njit(**_JIT)
def _settle(table, obs, settings, plan, out):
    """After every chunk: the columns and keys of the new landmarks, which are put in place,
    the weights normalised, N_eff, the reported particle and its report (the records as plain
    tuples, ``records``)."""
    table, obs, settings = Entries(*table), Observations(*obs), ReadingSettings(*settings)
    plan, out = ReadingPlan(*plan), ReadingOutputs(*out)
    count, num_particles = out.choice.shape
    new = NewLandmarks(np.empty((count, num_particles), np.bool_), np.empty(count, np.int64),
                       np.empty((count, num_particles), np.int64))
    taken, new_keys = _assign_columns(out.choice, obs.labels, settings.association == 0,
                                      plan.existing, plan.first_key, new.creating, new.column,
                                      new.keys)
    if not settings.localization:
        _place_new(table, plan.existing, out.choice, new, out.fresh, out.poses, obs, settings,
                   out.finite)
    n_eff, underflow, best, all_finite = _finish(out.poses, out.log_weights, settings.central,
                                                 out.finite)
    report_ids, report_new = _report(out.choice, new.creating, table.ident, best)
    return (report_ids, report_new, out.poses, out.log_weights, n_eff, underflow, best, taken,
            new_keys, all_finite)


@njit(**_JIT)
def _reading_serial(table, pending, particles, motion, ranges, bearings, labels, draws,
                    settings, plan, recorded):
    """The whole reading on the calling thread (``update_reading``; the records as plain
    tuples, ``records``)."""
    num_particles = recorded.shape[0]
    obs, out = _reading_buffers(ranges, bearings, labels, num_particles, settings, recorded)
    _reading_chunk(np.zeros(2, np.int64), num_particles, table, pending, particles, motion, obs,
                   draws, settings, plan, out)
    return _settle(table, obs, settings, plan, out)


def _reading_threaded(table, pending, particles, motion, ranges, bearings, labels, draws,
                      settings, plan, recorded, chunks):
    """``_reading_serial`` with its per-particle work shared by ``chunks`` threads: the
    calling thread and the crew's (``_Crew``), one hand-off per reading, each taking
    blocks of ``READING_BLOCK`` particles from one counter until none is left (so a thread
    that starts late or runs slower takes fewer). Blocks write disjoint particles, so the
    results are those of the serial reading."""
    num_particles = recorded.shape[0]
    obs, out = _reading_buffers(ranges, bearings, labels, num_particles, settings, recorded)
    _run_shared(_reading_chunk, chunks, (
        np.zeros(2, np.int64), READING_BLOCK, table, pending, particles, motion, obs, draws,
        settings, plan, out), num_particles)
    return _settle(table, obs, settings, plan, out)


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


_NO_MOTION = DeferredMotion(np.zeros((0, 2)), _NO_COV, np.zeros(6))
"""``DeferredMotion`` of a reading that propagates no covariance."""


_NO_ORDER = np.zeros(0, np.int64)


def update_reading(ws, particles: Particles, observations, draws: Draws,
                   settings: ReadingSettings, reach: float, first_key: int, propose: bool,
                   recorded: np.ndarray, order: np.ndarray | None = None, motion=None):
    """One reading for every particle, on the working set ``ws`` (updated in place), or, with
    ``order`` (a resampling not yet applied to ``ws``), on a new one whose particle m takes the
    entries of ``ws``'s particle ``order[m]`` (``WorkingSet.take``, in the reading's chunks).

    ``particles``: ``Particles`` whose ``cov`` is None when the observations are scored at the
    particles' poses (``mean`` is then ``poses``); ``observations``: the usable (ranges,
    bearings, labels) (``usable_observations``); ``draws``: the uniforms of ``monte_carlo``
    and the standard normals of the proposal's draw when ``propose``; ``first_key``: the
    store's next landmark key; ``recorded`` (M, 3): also given the new poses (the path
    history's next generation, ``PathHistory.next_generation``); ``motion``: the prior's turn,
    cov (or None) ``mean`` was moved from and the motion (``advance_mean``): the reading
    propagates the covariance in its blocks (then ``particles.cov`` is None). Returns (the
    reported particle's ``UpdateReport`` associated_ids (K,) and is_new (K,), poses (M, 3),
    normalised log weights (M,), N_eff, underflow, the reported particle, working-set columns
    taken, keys taken, all finite, the working set read).
    """
    return _update(ws, particles, observations, draws, settings, reach, first_key, propose,
                   recorded, order, crew.threads_for(particles.poses.shape[0]), motion)


def _update(ws, particles: Particles, observations, draws: Draws, settings: ReadingSettings,
            reach: float, first_key: int, propose: bool, recorded, order, threads: int,
            motion=None):
    """``update_reading`` on ``threads`` threads."""
    poses, log_weights, mean, cov = particles
    if motion is None:
        deferred, from_cov = _NO_MOTION, None
    else:
        turn, prior_cov, terms = motion
        from_cov = prior_cov is not None
        deferred = DeferredMotion(turn, prior_cov if from_cov else _NO_COV, terms)
        cov = np.empty((poses.shape[0], 3, 3))
    source = table = tuple(entries_of(ws))
    if order is None:
        order = _NO_ORDER
    else:
        ws = WorkingSet(*(np.empty_like(array) for array in source[:3]), ws.columns[order],
                        *(np.empty_like(array) for array in source[3:]), ws.first_new_slot)
        table = tuple(entries_of(ws))
    plan = reading_plan(settings, reach, first_key, ws.first_new_slot, cov is not None,
                        propose, from_cov)
    ranges, bearings, labels = (np.ascontiguousarray(values) for values in observations)
    # Plain tuples across the boundary (``records``).
    args = (table, (order, source), (poses, log_weights, mean, _NO_COV if cov is None else cov),
            tuple(deferred), ranges, bearings, labels, tuple(draws), tuple(settings),
            tuple(plan), recorded)
    if threads == 1:
        return _reading_serial(*args) + (ws,)
    return _reading_threaded(*args, threads) + (ws,)
