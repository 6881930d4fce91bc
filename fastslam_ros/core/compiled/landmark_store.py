# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""numba twin of ``core/landmark_store.py``: the gather of particles' landmarks into a working
set, the write-back of changed blocks, the claims of shared blocks (copy on write) and the
placing of new landmarks."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from . import crew
from ..landmark_store import LandmarkStore, STATE_WIDTH, WorkingSet
from .crew import _chunk_bounds, _run_chunks
from .jit import _JIT
from .records import Entries, entries_of


@njit(**_JIT)
def _gather_layout(pool, columns, num_new_slots):
    """The working set's ``Entries`` (unfilled, as a plain tuple: ``records``) for the cell
    ``columns`` of the store's ``pool`` (table, occupied, state, ident) and its width: the
    most landmarks any particle has there."""
    table, occupied = pool[0], pool[1]
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
            np.empty(shape, np.bool_), np.empty(shape, np.bool_),
            np.empty(shape, np.bool_)), width


@njit(**_JIT)
def _gather_chunk(lo, hi, pool, columns, entries):
    """Particles [lo, hi) of the working set's ``entries`` (``_gather_layout``'s): their
    landmarks of the cell ``columns`` in column then slot order, then empty entries (a unit
    covariance, so that scoring them stays finite)."""
    table, occupied, pool_state, pool_ident = pool
    row, slot, block, state, ident, valid, dirty, is_new = entries
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
def _gather_kernel(pool, columns, num_new_slots):
    entries, width = _gather_layout(pool, columns, num_new_slots)
    _gather_chunk(0, columns.shape[0], pool, columns, entries)
    return entries, width


def gather(store: LandmarkStore, columns: np.ndarray, num_new_slots: int) -> WorkingSet:
    """``LandmarkStore.gather`` (which brings the gathered columns up to date first): the same
    working set, in one compiled pass over the cells (from ``PARALLEL_MIN_PARTICLES`` on, one
    chunk of particles per thread)."""
    return _gather(store, columns, num_new_slots, crew.threads_for(store.num_particles))


def _gather(store: LandmarkStore, columns: np.ndarray, num_new_slots: int,
            threads: int) -> WorkingSet:
    """``gather`` on ``threads`` threads."""
    pool = (store.table, store.occupied, store.state, store.ident)
    cells = np.require(columns, np.int64, ("C", "W"))
    if threads == 1:
        entries, width = _gather_kernel(pool, cells, num_new_slots)
    else:
        entries, width = _gather_layout(pool, cells, num_new_slots)
        _run_chunks(_gather_chunk, _chunk_bounds(store.num_particles, threads),
                    (pool, cells, entries))
    row, slot, block, state, ident, valid, dirty, is_new = entries
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
def _write_back_kernel(entries, pairs, num_blocks, pool_state, occupied, origin):
    """``write_back`` of the working set's ``entries`` through the (particle, block, row)
    ``pairs`` (``entries`` a plain tuple from Python, ``records``)."""
    entries = Entries(*entries)
    dirty, row, block, slot, valid, ws_state = (entries.dirty, entries.row, entries.block,
                                                entries.slot, entries.valid, entries.state)
    pair_particles, pair_blocks, pair_rows = pairs
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
    _write_back_kernel(tuple(entries_of(ws)), (pair_particles, pair_blocks, pair_rows),
                       ws.columns.shape[1], pool_state, occupied, origin)


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
def _place_kernel(ws_state, ws_ident, new, origin, pending, rows, inverse, rank, state, ident,
                  occupied):
    """``place`` of the ``new`` entries (owner, entry, keys: ``new_entries``')."""
    owner, entry, keys = new
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
    return _place_kernel(ws.state, ws.ident, (owner, entry, keys), origin,
                         np.ascontiguousarray(pending, np.int64),
                         np.ascontiguousarray(rows, np.int64), inverse, rank, state, ident,
                         occupied)
