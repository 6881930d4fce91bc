# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Every particle's landmark map in shared, copy-on-write blocks indexed by spatial cell.

A *block* holds up to ``capacity`` landmarks of one spatial cell (side ``cell_size``). The pool
arrays (``mean``, ``cov``, ``logodds``, ...) are indexed by block row and slot; ``table[m, c]``
is the row that particle m uses for cell column c (-1: no landmark of m there). Resampling copies
only the ``table`` rows, and lazily, column by column (``ResampledTable``): it records the index
array, and the columns the filter reads (a few per cell change: those of the working set) are
brought up to date when read (all of them once every ``ResampledTable.MAX_PENDING``
resamplings), so a cell change costs about the same with 100 or 50,000 landmarks;
particles then share rows until one of them changes a landmark, at which point that particle
gets its own copy of the block (copy-on-write). Memory therefore grows with the number of
distinct blocks, not with M x N. Block references are counted exactly for the columns being
written (a block belongs to one column) and in full only when the pool runs out of free rows.

The filter works on a dense *working set*: ``gather`` copies the landmarks of some cells of every
particle into (M, K) arrays, the filter updates them over as many readings as the robot stays
among those cells (resampling reindexes the working set like the tables), and ``scatter``
writes the changed and new entries back (copying shared blocks first). Covariances are stored
packed as (xx, xy, yy), so they are symmetric by construction.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np

from .resampled_table import ResampledTable


MEAN, COV, LOGODDS = slice(0, 2), slice(2, 5), 5
"""Layout of the float record of a landmark: mean (x, y), packed covariance, log-odds."""
LABEL, KEY = 0, 1
"""Layout of the integer record: external label (-1: none) and store-wide key."""
STATE_WIDTH = 6


class StoreKernels(NamedTuple):
    """The compiled twins a ``LandmarkStore`` and its ``WorkingSetCache`` run instead of their
    numpy code (``compiled/landmark_store.py``, ``resampling.py``, ``reading.py``)."""

    claim_plan: Callable
    claim: Callable
    gather: Callable
    take: Callable
    dirty_pairs: Callable
    write_back: Callable
    new_entries: Callable
    insertion_pairs: Callable
    place: Callable
    block_records: Callable
    reindex: Callable
    """``WorkingSetCache.current``: a working set through a pending resampling."""
    pose_box: Callable
    """``WorkingSetCache.for_reading``: the box around the particles' positions."""

    @classmethod
    def compiled(cls) -> "StoreKernels":
        """The twins from ``core.compiled`` (numba needed)."""
        from . import compiled  # noqa: PLC0415 (optional dependency)
        return cls(compiled.claim_plan, compiled.claim, compiled.gather, compiled.take,
                   compiled.dirty_pairs, compiled.write_back, compiled.new_entries,
                   compiled.insertion_pairs, compiled.place, compiled.block_records,
                   compiled.reindex, compiled.pose_box)


class RecordViews:
    """Named views into packed landmark records (``state`` floats, ``ident`` integers)."""

    state: np.ndarray
    ident: np.ndarray

    @property
    def mean(self) -> np.ndarray:
        return self.state[..., MEAN]

    @property
    def cov(self) -> np.ndarray:
        return self.state[..., COV]

    @property
    def logodds(self) -> np.ndarray:
        return self.state[..., LOGODDS]

    @property
    def label(self) -> np.ndarray:
        return self.ident[..., LABEL]

    @property
    def key(self) -> np.ndarray:
        return self.ident[..., KEY]


@dataclass
class WorkingSet(RecordViews):
    """Landmarks of every particle near the robot as dense (M, K) arrays.

    Columns from ``first_new_slot`` on are empty slots where the filter places new landmarks
    (one column per observation that creates a landmark in some particle); the columns before
    it hold landmarks, gathered or created in earlier readings. ``mean``, ``cov``, ... are
    views into the packed ``state`` / ``ident`` records, so writing through them (also with
    fancy indices) updates the working set.
    """

    row: np.ndarray       # (M, K) pool row of the entry, -1 for a new slot
    slot: np.ndarray      # (M, K) slot within the row
    block: np.ndarray     # (M, K) index into ``columns[m]`` of the entry, -1 for a new slot
    columns: np.ndarray   # (M, B) cell columns that were gathered (-1: none)
    state: np.ndarray     # (M, K, 6) mean, packed covariance (xx, xy, yy), log-odds
    ident: np.ndarray     # (M, K, 2) label of the creating observation (-1: none), key
    valid: np.ndarray     # (M, K) entry holds a live landmark
    dirty: np.ndarray     # (M, K) gathered entry changed (updated, evidence, removed)
    is_new: np.ndarray    # (M, K) created since the gather
    first_new_slot: int

    @property
    def free_slots(self) -> int:
        """Empty columns left for new landmarks."""
        return self.valid.shape[1] - self.first_new_slot

    def covers(self, columns: np.ndarray) -> bool:
        """Every particle's cell ``columns`` ((M, C), -1 ignored) are in the working set."""
        held = (columns[:, :, None] == self.columns[:, None, :]).any(axis=2)
        return bool(np.all(held | (columns < 0)))

    def records_at(self, columns: np.ndarray) -> np.ndarray:
        """(..., M, 6) float records of each particle's column ``columns`` (..., M); entries of
        a negative column hold column 0's record (mask them)."""
        flat = np.maximum(columns, 0) + self.state.shape[1] * np.arange(self.state.shape[0])
        return self.state.reshape(-1, STATE_WIDTH)[flat]

    def take(self, indices: np.ndarray) -> "WorkingSet":
        """The working set after resampling: particle m takes the entries of ``indices[m]``."""
        return WorkingSet(self.row[indices], self.slot[indices], self.block[indices],
                          self.columns[indices], self.state[indices],
                          self.ident[indices], self.valid[indices], self.dirty[indices],
                          self.is_new[indices], self.first_new_slot)


class LandmarkStore(RecordViews):
    """Per-particle landmark maps with structural sharing (see module docstring)."""

    def __init__(self, num_particles: int, cell_size: float, capacity: int = 8,
                 initial_rows: int = 64, kernels: StoreKernels | None = None) -> None:
        self.num_particles = num_particles
        self.kernels = kernels
        """The compiled twins that gather working sets, write them back and read one
        particle's map (the cache reindexes with them too), or None: numpy."""
        self.cell_size = float(cell_size)
        self.capacity = capacity
        self.state = np.zeros((initial_rows, capacity, STATE_WIDTH))
        self.ident = np.full((initial_rows, capacity, 2), -1, dtype=np.int64)
        self.occupied = np.zeros((initial_rows, capacity), dtype=bool)
        self.refcount = np.zeros(initial_rows, dtype=np.int64)
        """References to each row: exact for the rows of the columns being written; for the
        others, 0 only where no particle references the row (resampling copies and drops
        references without counting them; ``recount`` counts them all)."""
        self.tables = ResampledTable(num_particles, 16)
        """``table``, whose columns follow resampling lazily."""
        self.cell_ix = np.zeros(16, dtype=np.int64)
        self.cell_iy = np.zeros(16, dtype=np.int64)
        self.num_cells = 0
        self._cell_columns: dict[tuple[int, int], int] = {}
        self.next_key = 0
        # Known association: column of the landmark with a given label, per particle.
        self._label_index: dict[int, int] = {}
        self.label_tables = ResampledTable(num_particles, 8)
        """``label_column``: column of each particle's landmark of a label index."""

    @property
    def table(self) -> np.ndarray:
        """(M, columns) row of each particle's block of each cell column (-1: none); current
        for the columns refreshed (all of them after ``apply_resampling``)."""
        return self.tables.data

    @property
    def label_column(self) -> np.ndarray:
        return self.label_tables.data

    # ------------------------------------------------------------------ memory
    @property
    def num_rows(self) -> int:
        return self.refcount.shape[0]

    def rows_in_use(self) -> int:
        """Distinct blocks referenced by at least one particle."""
        self.apply_resampling()
        return int(np.count_nonzero(self.refcount))

    def nbytes(self) -> int:
        """Bytes held by the pool, the tables and the cell index."""
        arrays = (self.state, self.ident, self.occupied, self.refcount, self.table, self.cell_ix,
                  self.cell_iy, self.label_column)
        return int(sum(a.nbytes for a in arrays))

    # ------------------------------------------------------------------ cells
    def cell_of(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Integer cell coordinates of points (..., 2)."""
        cells = np.floor(points / self.cell_size).astype(np.int64)
        return cells[..., 0], cells[..., 1]

    def cell_box(self, low: np.ndarray, high: np.ndarray) -> tuple[int, int, int, int]:
        """(lowest x, lowest y, highest x, highest y) cell of the axis-aligned box [low, high],
        as Python ints (the filter compares boxes on every reading)."""
        (lx, ly), (hx, hy) = (v.tolist() if type(v) is np.ndarray else v for v in (low, high))
        size = self.cell_size
        return math.floor(lx / size), math.floor(ly / size), math.floor(hx / size), \
            math.floor(hy / size)

    def columns_in_box(self, low: np.ndarray, high: np.ndarray) -> np.ndarray:
        """Columns of the known cells that intersect the axis-aligned box [low, high]."""
        lo_x, lo_y, hi_x, hi_y = self.cell_box(low, high)
        ix, iy = self.cell_ix[:self.num_cells], self.cell_iy[:self.num_cells]
        return np.flatnonzero((ix >= lo_x) & (ix <= hi_x) & (iy >= lo_y) & (iy <= hi_y))

    def _columns_for_cells(self, ix: np.ndarray, iy: np.ndarray) -> np.ndarray:
        """Insertion columns of cells (registering new ones); one look-up per distinct cell.

        A cell may own several columns (when its blocks fill up); new landmarks go to the
        newest one.
        """
        # One integer per cell (|iy| < 2^31 cells), so the 1-D unique applies.
        keys, first, inverse = np.unique(ix * 2 ** 32 + iy, return_index=True,
                                         return_inverse=True)
        columns = np.empty(len(keys), dtype=np.int64)
        for i, (cx, cy) in enumerate(zip(ix[first].tolist(), iy[first].tolist())):
            column = self._cell_columns.get((cx, cy))
            if column is None:
                column = self._register_cell(cx, cy)
            columns[i] = column
        return columns[inverse.reshape(-1)]

    def _register_cell(self, cx: int, cy: int) -> int:
        """A new column for cell (cx, cy), which becomes its insertion column."""
        column = self.num_cells
        if column == self.tables.width:
            grow = self.tables.width
            self.tables.widen(grow)
            self.cell_ix = np.concatenate([self.cell_ix, np.zeros(grow, np.int64)])
            self.cell_iy = np.concatenate([self.cell_iy, np.zeros(grow, np.int64)])
        self.cell_ix[column], self.cell_iy[column] = cx, cy
        self._cell_columns[(cx, cy)] = column
        self.num_cells += 1
        return column

    # ------------------------------------------------------------------ labels (known ids)
    def label_columns(self, labels: np.ndarray) -> np.ndarray:
        """(M, len(labels)) column of each particle's landmark with that label, -1 if none."""
        index = self._label_indices(labels, create=False)
        self.label_tables.refresh(index)
        columns = self.label_column[:, np.maximum(index, 0)]
        return np.where(index[None, :] >= 0, columns, -1)

    def _label_indices(self, labels: np.ndarray, create: bool) -> np.ndarray:
        """Dense index of each label (-1 if unknown and not ``create``); one dict look-up per
        distinct label, not per particle."""
        distinct, inverse = np.unique(labels, return_inverse=True)
        lookup = self._label_slot if create else (lambda v: self._label_index.get(v, -1))
        return np.array([lookup(int(v)) for v in distinct], np.int64)[inverse.reshape(-1)]

    def _label_slot(self, label: int) -> int:
        index = self._label_index.get(label)
        if index is None:
            index = len(self._label_index)
            self._label_index[label] = index
            if index == self.label_tables.width:
                self.label_tables.widen(self.label_tables.width)
        return index

    # ------------------------------------------------------------------ pool rows
    def _allocate_rows(self, count: int) -> np.ndarray:
        """``count`` unused rows (refcount set to 1), growing the pool when needed.

        Rows that resampling left unreferenced are found by a full ``recount`` once the free
        rows run out; the pool then doubles unless a quarter of it is free, so full counts
        stay rare (amortised O(1) per row handed out)."""
        free = np.flatnonzero(self.refcount == 0)
        if len(free) < count:
            self.recount()
            free = np.flatnonzero(self.refcount == 0)
            if len(free) < max(count, self.num_rows // 4):
                self._grow_rows(max(self.num_rows, count - len(free)))
                free = np.flatnonzero(self.refcount == 0)
        rows = free[:count]
        self.refcount[rows] = 1
        return rows

    def _grow_rows(self, extra: int) -> None:
        def grow(array: np.ndarray, fill) -> np.ndarray:
            pad = np.full((extra,) + array.shape[1:], fill, dtype=array.dtype)
            return np.concatenate([array, pad])
        self.state, self.ident = grow(self.state, 0.0), grow(self.ident, -1)
        self.occupied, self.refcount = grow(self.occupied, False), grow(self.refcount, 0)

    def _own_rows(self, particles: np.ndarray, columns: np.ndarray) -> np.ndarray:
        """Make the blocks (particle, column) private to their particle; return their rows.

        Shared blocks are copied; missing blocks are created empty. Pairs must be unique.
        """
        if self.kernels is not None:
            self.tables.refresh(columns)
            rows, needed, count = self.kernels.claim_plan(self.table, particles, columns,
                                                          self.refcount)
            if count == 0:
                return rows
            fresh = self._allocate_rows(count)
            return self.kernels.claim(self.table, particles, columns, rows, needed, fresh,
                                      self.refcount, self.state, self.ident, self.occupied)
        self._count_columns(columns)
        rows = self.table[particles, columns]
        missing = rows < 0
        shared = ~missing & (self.refcount[np.maximum(rows, 0)] > 1)
        needed = missing | shared
        if np.any(needed):
            # One allocation: a full recount inside it must not see rows handed out here.
            placed = np.empty(len(rows), np.int64)
            placed[needed] = self._allocate_rows(int(needed.sum()))
            self.occupied[placed[missing]] = False
            old, copies = rows[shared], placed[shared]
            for array in (self.state, self.ident, self.occupied):
                array[copies] = array[old]
            np.subtract.at(self.refcount, old, 1)
            rows[needed] = placed[needed]
        self.table[particles, columns] = rows
        return rows

    def _count_columns(self, columns: np.ndarray) -> None:
        """Bring these cell columns up to date and count the references to their rows exactly
        (a row belongs to one column, so these columns hold all of its references)."""
        self.tables.refresh(columns)
        referenced = self.table[:, np.unique(columns)].ravel()
        referenced = referenced[referenced >= 0]
        if len(referenced):
            counts = np.bincount(referenced, minlength=self.num_rows)
            rows = np.unique(referenced)
            self.refcount[rows] = counts[rows]

    def recount(self) -> None:
        """Bring every column up to date and count every row's references."""
        self.tables.refresh_all()
        # Shifted by one, so that -1 (no block) lands in bin 0: cheaper than masking it out.
        shifted = self.table[:, :self.num_cells] + 1
        self.refcount = np.bincount(shifted.ravel(), minlength=self.num_rows + 1)[1:]

    # ------------------------------------------------------------------ working set
    def gather(self, columns: np.ndarray, num_new_slots: int) -> WorkingSet:
        """Copy the landmarks of cell ``columns`` ((M, C), -1 ignored) into a working set with
        ``num_new_slots`` empty columns for new landmarks."""
        self.tables.refresh(columns)
        if self.kernels is not None:
            return self.kernels.gather(self, columns, num_new_slots)
        num_particles = self.num_particles
        particle = np.arange(num_particles)[:, None]
        rows = np.where(columns >= 0, self.table[particle, np.maximum(columns, 0)], -1)
        occupied = self.occupied[np.maximum(rows, 0)] & (rows >= 0)[..., None]
        owner, flat = np.nonzero(occupied.reshape(num_particles, -1))
        counts = np.bincount(owner, minlength=num_particles)
        width = int(counts.max(initial=0))
        rank = np.arange(len(owner)) - (np.cumsum(counts) - counts)[owner]
        block, slot = np.divmod(flat, self.capacity)
        src_row = rows[owner, block]

        total = width + num_new_slots
        shape = (num_particles, total)
        # Empty slots get a unit covariance so that scoring them stays finite.
        state = np.zeros(shape + (STATE_WIDTH,))
        state[..., 2] = state[..., 4] = 1.0
        ident = np.full(shape + (2,), -1, np.int64)
        # Records move by one flat row index each (much cheaper than (row, slot) pairs).
        source = src_row * self.capacity + slot
        target = owner * total + rank
        state.reshape(-1, STATE_WIDTH)[target] = self.state.reshape(-1, STATE_WIDTH)[source]
        ident.reshape(-1, 2)[target] = self.ident.reshape(-1, 2)[source]
        ws = WorkingSet(row=np.full(shape, -1, np.int64), slot=np.zeros(shape, np.int64),
                        block=np.full(shape, -1, np.int64), columns=columns, state=state,
                        ident=ident, valid=np.zeros(shape, bool), dirty=np.zeros(shape, bool),
                        is_new=np.zeros(shape, bool), first_new_slot=width)
        ws.row.flat[target] = src_row
        ws.slot.flat[target] = slot
        ws.block.flat[target] = block
        ws.valid.flat[target] = True
        return ws

    def scatter(self, ws: WorkingSet, track_labels: bool,
                order: np.ndarray | None = None) -> None:
        """Write changed and new working-set entries back, copying shared blocks first.

        ``order``: a resampling not yet applied to ``ws`` (particle m's entries are those of
        its particle ``order[m]``); the compiled write-back reads through it, the numpy one
        (and the compiled one with known ids, whose labels are tracked per particle) applies
        it first (``WorkingSet.take``)."""
        if order is not None and (self.kernels is None or track_labels):
            ws = ws.take(order) if self.kernels is None else self.kernels.take(ws, order)
            order = None
        origin = np.arange(self.num_particles) if order is None else order
        self._write_existing(ws, track_labels, origin)
        self._insert_new(ws, track_labels, origin)

    def gather_maps(self, particles: np.ndarray) -> WorkingSet:
        """A working set of every cell of the ``particles``' maps (the other particles' rows
        empty), for a rare change of whole maps (a loop closure)."""
        columns = np.full((self.num_particles, self.num_cells), -1, np.int64)
        columns[particles] = np.arange(self.num_cells)
        return self.gather(columns, num_new_slots=0)

    def scatter_moved(self, ws: WorkingSet, track_labels: bool) -> None:
        """``scatter``, where gathered entries may have moved to another cell: those leave
        their block and are inserted in the blocks of the cells they now lie in."""
        ix, iy = self.cell_of(ws.mean)
        column = ws.columns[np.arange(ws.valid.shape[0])[:, None], np.maximum(ws.block, 0)]
        moved = (ws.valid & (ws.row >= 0)
                 & ((self.cell_ix[column] != ix) | (self.cell_iy[column] != iy)))
        owner, entry = np.nonzero(moved)
        counts = np.bincount(owner, minlength=ws.valid.shape[0])
        shape = (ws.valid.shape[0], int(counts.max(initial=0)))
        rank = np.arange(len(owner)) - (np.cumsum(counts) - counts)[owner]
        state = np.zeros(shape + (STATE_WIDTH,))
        ident = np.full(shape + (2,), -1, np.int64)
        state[owner, rank], ident[owner, rank] = ws.state[owner, entry], ws.ident[owner, entry]
        placed = np.zeros(shape, bool)
        placed[owner, rank] = True
        moving = WorkingSet(row=np.full(shape, -1, np.int64), slot=np.zeros(shape, np.int64),
                            block=np.full(shape, -1, np.int64), columns=ws.columns,
                            state=state, ident=ident, valid=placed,
                            dirty=np.zeros(shape, bool), is_new=placed, first_new_slot=0)
        ws.valid[moved] = False
        ws.dirty[moved] = True
        origin = np.arange(self.num_particles)
        self._write_existing(ws, track_labels, origin)
        self._insert_new(moving, track_labels, origin)

    def _write_existing(self, ws: WorkingSet, track_labels: bool, origin: np.ndarray) -> None:
        if self.kernels is not None:
            pair_particle, pair_block = self.kernels.dirty_pairs(ws, origin)
            if len(pair_particle) == 0:
                return
            rows = self._own_rows(pair_particle, ws.columns[origin[pair_particle], pair_block])
            self.kernels.write_back(ws, pair_particle, pair_block, rows, self.state,
                                    self.occupied, origin)
            if track_labels:
                self._forget_labels(ws, *np.nonzero(ws.dirty & (ws.row >= 0) & ~ws.valid))
            return
        owner, entry = np.nonzero(ws.dirty & (ws.row >= 0))
        if len(owner) == 0:
            return
        # Distinct (particle, gathered block) pairs, through a small dense marker.
        block = ws.block[owner, entry]
        marker = np.zeros(ws.columns.shape, bool)
        marker[owner, block] = True
        pair_particle, pair_block = np.nonzero(marker)
        position = np.cumsum(marker.ravel()) - 1
        rows = self._own_rows(pair_particle, ws.columns[pair_particle, pair_block])
        rows = rows[position[owner * ws.columns.shape[1] + block]]
        slots = ws.slot[owner, entry]
        keep = ws.valid[owner, entry]
        target = rows * self.capacity + slots
        self.state.reshape(-1, STATE_WIDTH)[target] = ws.state[owner, entry]
        self.occupied.flat[target] = keep
        if track_labels and not np.all(keep):
            self._forget_labels(ws, owner[~keep], entry[~keep])

    def _forget_labels(self, ws: WorkingSet, owner: np.ndarray, entry: np.ndarray) -> None:
        """Known ids: removed working-set entries (owner, entry) no longer hold their label."""
        if len(owner) == 0:
            return
        index = self._label_indices(ws.label[owner, entry], create=False)
        known = index >= 0
        self.label_tables.refresh(index[known])
        self.label_column[owner[known], index[known]] = -1

    def _insert_new(self, ws: WorkingSet, track_labels: bool, origin: np.ndarray) -> None:
        """Put new landmarks in their cell's block, opening another column when it is full
        (the keyless ones get their keys first); ``origin``: as in ``_write_existing``
        (the identity on the numpy path)."""
        if self.kernels is not None:
            owner, entry, ix, iy, keys, taken = self.kernels.new_entries(
                ws, self.cell_size, self.next_key, origin)
            self.next_key += taken
            place = functools.partial(self._place_compiled, keys, origin)
        else:
            owner, entry = np.nonzero(ws.is_new & ws.valid)
            keyless = ws.key[owner, entry] < 0
            ws.key[owner[keyless], entry[keyless]] = self.new_keys(int(keyless.sum()))
            ix, iy = self.cell_of(ws.mean[owner, entry])
            place = self._place_numpy
        if len(owner) == 0:
            return
        columns = self._columns_for_cells(ix, iy)
        pending = np.arange(len(owner))
        while len(pending):
            pending = pending[~place(ws, owner, entry, columns, pending)]
            if len(pending):
                # Full blocks: the cells get a fresh insertion column for everyone.
                for cx, cy in np.unique(np.stack([ix[pending], iy[pending]], 1), axis=0).tolist():
                    self._register_cell(cx, cy)
                columns[pending] = self._columns_for_cells(ix[pending], iy[pending])
        if track_labels:
            labels = ws.label[owner, entry]
            index = self._label_indices(labels, create=True)
            self.label_tables.refresh(index)
            self.label_column[owner, index] = columns

    def _place_numpy(self, ws: WorkingSet, owner: np.ndarray, entry: np.ndarray,
                     columns: np.ndarray, pending: np.ndarray) -> np.ndarray:
        """Put the ``pending`` new entries (owner, entry) in a free slot of their particle's
        block of their insertion column (made private first), in order; which fitted."""
        width = self.table.shape[1]
        pair_key = owner[pending] * width + columns[pending]
        pairs, inverse = np.unique(pair_key, return_inverse=True)
        inverse = inverse.reshape(-1)
        order = np.argsort(pair_key, kind="stable")
        rank = np.empty(len(pending), np.int64)
        rank[order] = np.arange(len(pending)) - np.searchsorted(pair_key[order],
                                                                 pair_key[order])
        pair_particle, pair_column = np.divmod(pairs, width)
        rows = self._own_rows(pair_particle, pair_column)[inverse]
        position = np.cumsum(~self.occupied[rows], axis=1)
        fits = position[:, -1] > rank
        slots = np.argmax(position > rank[:, None], axis=1)
        rows, slots, done = rows[fits], slots[fits], pending[fits]
        self.occupied[rows, slots] = True
        self.state[rows, slots] = ws.state[owner[done], entry[done]]
        self.ident[rows, slots] = ws.ident[owner[done], entry[done]]
        return fits

    def _place_compiled(self, keys: np.ndarray, origin: np.ndarray, ws: WorkingSet,
                        owner: np.ndarray, entry: np.ndarray, columns: np.ndarray,
                        pending: np.ndarray) -> np.ndarray:
        """``_place_numpy`` with the compiled backend (the entries' ``keys`` given, ``ws``
        read through ``origin``): the insertion pairs and the placing each in one call."""
        pair_particle, pair_column, inverse, rank = self.kernels.insertion_pairs(
            owner, columns, pending, self.table.shape[1])
        rows = self._own_rows(pair_particle, pair_column)
        return self.kernels.place(ws, owner, entry, keys, origin, pending, rows, inverse, rank,
                                  self.state, self.ident, self.occupied)

    def new_keys(self, count: int) -> np.ndarray:
        """``count`` store-wide landmark keys never handed out before."""
        keys = self.next_key + np.arange(count)
        self.next_key += count
        return keys

    # ------------------------------------------------------------------ resampling and queries
    def resample(self, indices: np.ndarray) -> None:
        """Particle m takes the map of particle ``indices[m]``: tables only, blocks shared.

        Deferred: the tables, whose size grows with the map, are reindexed column by column
        when read (``ResampledTable``).
        """
        self.tables.resample(indices)
        self.label_tables.resample(indices)

    def apply_resampling(self) -> None:
        """Reindex the whole tables by the resampling deferred so far and recount all block
        references (the filter itself only ever reads the columns it needs)."""
        self.label_tables.refresh_all()
        self.recount()

    def particle_map(self, particle: int, skip_columns: np.ndarray | None = None):
        """(mean (N,2), cov packed (N,3), logodds (N,), label (N,), key (N,)) of one particle,
        leaving out the cell ``skip_columns`` (-1 ignored)."""
        rows = self.tables.row(particle, self.num_cells)
        if skip_columns is not None:
            rows[skip_columns[skip_columns >= 0]] = -1
        if self.kernels is not None:
            state, ident = self.kernels.block_records(rows, self.occupied, self.state,
                                                      self.ident)
        else:
            rows = rows[rows >= 0]
            mask = self.occupied[rows]
            state, ident = self.state[rows][mask], self.ident[rows][mask]
        return (state[:, MEAN], state[:, COV], state[:, LOGODDS], ident[:, LABEL],
                ident[:, KEY])
