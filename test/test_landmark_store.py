# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Copy-on-write landmark store: sharing after resampling, isolation of writes, overflow."""
from __future__ import annotations

import numpy as np

from fastslam_ros.core.landmark_store import LandmarkStore
from fastslam_ros.core.resampled_table import ResampledTable
from model_helpers import edit_box, insert, landmark_counts


def test_resampled_particles_share_blocks_until_one_writes():
    store = LandmarkStore(4, cell_size=5.0)
    points = np.array([[1.0, 1.0], [12.0, 3.0], [-7.0, 8.0]])
    insert(store, 0, points)
    rows_before = store.rows_in_use()
    store.resample(np.zeros(4, np.int64))
    assert store.rows_in_use() == rows_before          # shared, not copied
    # Particle 2 moves its first landmark: only that block gets copied, and only for it.
    columns = store.columns_in_box(np.array([-100, -100]), np.array([100, 100]))
    ws = store.gather(np.broadcast_to(columns, (4, len(columns))), 0)
    target = np.flatnonzero(np.all(ws.mean[2] == points[0], axis=1))[0]
    ws.mean[2, target] = (1.5, 1.5)
    ws.dirty[2, target] = True
    store.scatter(ws, track_labels=False)
    assert store.rows_in_use() == rows_before + 1
    for particle in range(4):
        mean = store.particle_map(particle)[0]
        moved = np.any(np.all(mean == (1.5, 1.5), axis=1))
        assert moved == (particle == 2)
        assert len(mean) == 3


def test_removed_landmark_disappears_only_for_its_particle():
    store = LandmarkStore(3, cell_size=5.0)
    insert(store, 0, np.array([[1.0, 1.0], [2.0, 2.0]]))
    store.resample(np.zeros(3, np.int64))
    columns = store.columns_in_box(np.array([-10, -10]), np.array([10, 10]))
    ws = store.gather(np.broadcast_to(columns, (3, len(columns))), 0)
    ws.valid[1, 0] = False
    ws.dirty[1, 0] = True
    store.scatter(ws, track_labels=False)
    np.testing.assert_array_equal(landmark_counts(store), [2, 1, 2])


def test_full_cells_overflow_into_new_columns_and_keep_every_landmark():
    store = LandmarkStore(2, cell_size=10.0, capacity=4)
    rng = np.random.default_rng(0)
    points = rng.uniform(0.0, 9.9, (11, 2))             # all in one cell
    insert(store, 1, points)
    assert store.num_cells == 3                          # ceil(11 / 4) columns for the cell
    mean = store.particle_map(1)[0]
    np.testing.assert_allclose(np.sort(mean[:, 0]), np.sort(points[:, 0]))
    assert len(store.particle_map(0)[0]) == 0
    keys = store.particle_map(1)[4]
    assert len(np.unique(keys)) == 11


def test_label_index_finds_landmarks_anywhere_and_forgets_removed_ones():
    store = LandmarkStore(2, cell_size=5.0)
    insert(store, 0, np.array([[1.0, 1.0], [40.0, -3.0]]), labels=np.array([7, 9]))
    columns = store.label_columns(np.array([7, 9, 11]))
    assert columns[0, 0] >= 0 and columns[0, 1] >= 0 and columns[0, 2] == -1
    assert np.all(columns[1] == -1)
    ws = store.gather(columns[:, :2], 0)
    where = np.flatnonzero(ws.label[0] == 9)[0]
    ws.valid[0, where] = False
    ws.dirty[0, where] = True
    store.scatter(ws, track_labels=True)
    assert store.label_columns(np.array([9]))[0, 0] == -1


def test_memory_grows_with_distinct_blocks_not_particles():
    store = LandmarkStore(100, cell_size=10.0)
    rng = np.random.default_rng(1)
    insert(store, 0, rng.uniform(-500, 500, (5000, 2)))
    store.resample(np.zeros(100, np.int64))
    record = 6 * 8 + 2 * 8 + 1
    assert store.nbytes() < 0.2 * 100 * 5000 * record


def test_deferred_resamplings_compose_like_applied_ones():
    store = LandmarkStore(4, cell_size=5.0)
    for particle in range(4):
        insert(store, particle, np.array([[float(particle), 0.0], [30.0, 10.0 * particle]]))
    first, second = np.array([3, 3, 0, 1]), np.array([2, 0, 0, 3])
    store.resample(first)
    store.resample(second)
    expected = first[second]                             # particle m now holds first[second[m]]
    deferred = [store.particle_map(m)[0] for m in range(4)]
    store.apply_resampling()
    for particle in range(4):
        original = np.array([[float(expected[particle]), 0.0], [30.0, 10.0 * expected[particle]]])
        for mean in (deferred[particle], store.particle_map(particle)[0]):
            np.testing.assert_array_equal(mean[np.argsort(mean[:, 1])],
                                          original[np.argsort(original[:, 1])])
    # Blocks are counted again from the applied tables: maps 0, 3 and 1 survive, 2 blocks each.
    assert store.rows_in_use() == 6


def test_lazy_table_columns_match_eager_reindexing():
    rng = np.random.default_rng(3)
    table = ResampledTable(6, 5)
    table.data[:] = rng.integers(-1, 50, table.data.shape)
    eager = table.data.copy()
    for step in range(200):
        indices = rng.integers(0, 6, 6)
        table.resample(indices)
        eager = eager[indices]
        if step % 7 == 0:
            table.widen(3)
            eager = np.concatenate([eager, np.full((6, 3), -1, np.int32)], axis=1)
        columns = rng.integers(-1, table.width, 3)
        table.refresh(columns)
        fresh = columns[columns >= 0]
        np.testing.assert_array_equal(table.data[:, fresh], eager[:, fresh])
        particle = int(rng.integers(0, 6))
        np.testing.assert_array_equal(table.row(particle, table.width), eager[particle])
    table.refresh_all()
    np.testing.assert_array_equal(table.data, eager)


def test_lazy_store_keeps_the_maps_of_an_eager_one():
    """Random resamplings, updates, removals and insertions: every particle's map equals a
    plain {label: position} dict per particle kept by hand, and the store equals one that
    reindexes its tables at every resampling (same maps, labels and block count)."""
    rng = np.random.default_rng(5)
    count = 5
    lazy, eager = LandmarkStore(count, 5.0, capacity=3), LandmarkStore(count, 5.0, capacity=3)
    eager.tables.MAX_PENDING = eager.label_tables.MAX_PENDING = 0
    expected: list[dict[int, np.ndarray]] = [{} for _ in range(count)]
    for step in range(120):
        if step % 3 == 0:
            points = rng.uniform(-30.0, 30.0, (4, 2))
            particle = int(rng.integers(0, count))
            labels = 100 * step + np.arange(4)
            for store in (lazy, eager):
                insert(store, particle, points, labels)
            expected[particle].update(zip(labels.tolist(), points))
        indices = np.sort(rng.integers(0, count, count))
        low = rng.uniform(-30.0, 20.0, 2)
        change = rng.random(64)
        expected = [dict(expected[i]) for i in indices]
        for store in (lazy, eager):
            store.resample(indices)
            touched = edit_box(store, low, change, 0.3, 0.05)
        for particle, label, removed in touched:
            if removed:
                del expected[particle][label]
            else:
                expected[particle][label] = expected[particle][label] + 0.01
        for particle in range(count):
            mean, _, _, label, _ = lazy.particle_map(particle)
            assert sorted(label.tolist()) == sorted(expected[particle])
            for position, one in zip(mean, label.tolist()):
                np.testing.assert_allclose(position, expected[particle][one], atol=1e-12)
            ours, theirs = lazy.particle_map(particle), eager.particle_map(particle)
            for a, b in zip(ours, theirs):  # labels are unique: the same order by label
                np.testing.assert_array_equal(a[np.argsort(ours[3])], b[np.argsort(theirs[3])])
        np.testing.assert_array_equal(lazy.label_columns(np.arange(0, 100 * step + 4, 37)),
                                      eager.label_columns(np.arange(0, 100 * step + 4, 37)))
    assert lazy.rows_in_use() == eager.rows_in_use()
