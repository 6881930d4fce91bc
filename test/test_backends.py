# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The compiled backend against the numpy one at a larger M, and the core without numba.

Each numba twin in ``core/compiled/`` and the numpy module it mirrors, and the tests that run
both on the same draws:

- ``association``, ``proposal``, ``landmark_ekf`` (inside ``reading``) vs ``core.association``,
  ``core.proposal``, ``core.landmark_ekf`` through ``FastSLAM``: the whole-reading tests
  ``test_compiled_backend_makes_the_same_choices_as_numpy``,
  ``test_parallel_reading_makes_the_same_choices_as_numpy``,
  ``test_loop_closure_shifts_the_same_particles_on_both_backends``,
  ``test_existence_from_a_detection_probability_is_the_same_on_both_backends``;
- ``motion`` vs ``core.motion``: ``test_prior_moved_in_the_reading_matches_numpy``,
  ``test_compiled_odometry_prior_matches_the_numpy_steps``,
  ``test_turn_faults_are_the_same_on_both_backends``;
- ``resampling`` vs ``core.resampling``:
  ``test_compiled_systematic_resampling_draws_the_numpy_indices``,
  ``test_compiled_take_matches_the_working_set_take``,
  ``test_in_place_reindex_matches_the_working_set_take``,
  ``test_compiled_resampling_of_the_poses_matches_numpy``;
- ``path_history`` vs ``core.path_history``:
  ``test_compiled_path_pruning_keeps_the_numpy_history``;
- ``landmark_store`` vs ``core.landmark_store``: ``test_compiled_gather_matches_the_store_gather``,
  ``test_compiled_write_back_leaves_the_store_of_the_numpy_one``,
  ``test_compiled_write_back_reads_through_a_pending_resampling``;
- ``crew``: ``test_crew_runs_each_job_and_raises_a_workers_error_here``.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fastslam_ros.core import FastSLAM, FastSLAMConfig
from fastslam_ros.core.config import numba_available
from fastslam_ros.core.landmark_store import LandmarkStore, StoreKernels, WorkingSet
from fastslam_ros.core.resampling import systematic_resample
from fastslam_ros.tools.simulation.synthetic import make_world
from model_helpers import edit_box

from conftest import REPO_ROOT

needs_numba = pytest.mark.skipif(not numba_available(),
                                 reason="numba is not installed: no compiled backend to compare")


@needs_numba
@pytest.mark.parametrize("algorithm", ["fastslam1", "fastslam2"])
@pytest.mark.parametrize("association", ["known", "ml", "monte_carlo", "two_gate"])
def test_compiled_backend_makes_the_same_choices_as_numpy(algorithm, association):
    """Same draws: identical associations, creations, removals and resampling; floats 1e-9."""
    assert_same_run(algorithm, association)


@needs_numba
@pytest.mark.parametrize("algorithm", ["fastslam1", "fastslam2"])
def test_turn_faults_are_the_same_on_both_backends(algorithm):
    """``turn_fault_probability``: the same particles take the same turn errors."""
    assert_same_run(algorithm, "ml", turn_fault_probability=0.2)


@needs_numba
@pytest.mark.parametrize("algorithm,association", [("fastslam1", "monte_carlo"),
                                                   ("fastslam2", "ml")])
def test_parallel_reading_makes_the_same_choices_as_numpy(algorithm, association,
                                                          monkeypatch):
    """The reading split into chunks of particles on two threads (what M >= 500 runs with
    two cores) gives the numpy reference's results too."""
    from fastslam_ros.core import compiled as kernels
    monkeypatch.setattr(kernels.crew, "threads_for", lambda num_particles: 2)
    assert_same_run(algorithm, association)


@needs_numba
@pytest.mark.parametrize("association", ["ml", "monte_carlo"])
def test_loop_closure_shifts_the_same_particles_on_both_backends(association):
    """The loop-closure step (a numpy step after either backend's reading) sees identical
    states, so it closes the same loops: poses and weights equal at every step."""
    from test_loop_closure import run_drifting_loop
    runs = [run_drifting_loop(2, backend, association=association)
            for backend in ("numpy", "numba")]
    assert [slam.backend for slam, *_ in runs] == ["numpy", "numba"]
    assert runs[0][0].loop.num_closures == runs[1][0].loop.num_closures > 0
    for (poses, log_weights), (other_poses, other_log_weights) in zip(runs[0][3], runs[1][3]):
        np.testing.assert_allclose(poses, other_poses, atol=1e-9, rtol=0)
        np.testing.assert_allclose(log_weights, other_log_weights, atol=1e-9, rtol=0)
    np.testing.assert_allclose(runs[0][0].best_map().means, runs[1][0].best_map().means,
                               atol=1e-9, rtol=0)


@needs_numba
@pytest.mark.parametrize("threads", [1, 2])
def test_prior_moved_in_the_reading_matches_numpy(threads, monkeypatch):
    """FastSLAM 2.0's prior moved by ``advance_mean``, its covariance propagated in the next
    reading's blocks: from none, from a prior moved by an earlier ``predict`` (its covariance
    then propagated at once), and too wide (sampled): the numpy reference's results."""
    from fastslam_ros.core import compiled as kernels
    from fastslam_ros.core.fastslam import MAX_PRIOR_HEADING_SIGMA
    monkeypatch.setattr(kernels.crew, "threads_for", lambda num_particles: threads)
    seen = set()
    advance_mean = kernels.advance_mean

    def watched(prior, poses, delta, settings):
        moved, widest, turn, motion = advance_mean(prior, poses, delta, settings)
        seen.add((prior is not None, bool(widest > MAX_PRIOR_HEADING_SIGMA ** 2)))
        return moved, widest, turn, motion
    monkeypatch.setattr(kernels, "advance_mean", watched)
    for alpha2 in (0.05, 0.2):
        assert_same_run("fastslam2", "ml", halves=True, alpha2=alpha2,
                        max_pending_translation=0.15)
    assert {(False, False), (True, False), (True, True)} <= seen


def assert_same_run(algorithm: str, association: str, halves: bool = False,
                    **overrides) -> None:
    """Run numpy and numba side by side on one synthetic world and compare every step
    (``halves``: the odometry of each step in two ``predict`` calls; ``overrides``: config
    fields)."""
    world = make_world(seed=3, num_landmarks=20, extent=24.0, num_steps=60, max_range=9.0,
                       clutter_per_step=0.5, detection_probability=0.85)
    base = FastSLAMConfig(num_particles=150, algorithm=algorithm, association=association,
                          sigma_range=0.1, sigma_bearing=0.02, max_range=9.0, cell_size=5.0,
                          new_landmark_likelihood=1e-3, sensor_x=0.2, resample_threshold=0.8,
                          logodds_missed=-0.7, logodds_remove=-1.0).replace(**overrides)
    filters = [FastSLAM(base.replace(backend=name), rng=np.random.default_rng(4),
                        initial_pose=world.steps[0].truth) for name in ("numpy", "numba")]
    assert [slam.backend for slam in filters] == ["numpy", "numba"]
    previous = world.steps[0].odometry
    resampled = 0
    for k, step in enumerate(world.steps[1:]):
        ids = step.ids if association != "known" else np.maximum(step.ids, 0)
        ranges, bearings = step.ranges, step.bearings
        if k % 7 == 3:  # observations the filter must skip (NaN, at the origin, inf, no id)
            ranges = np.append(ranges, [np.nan, 1e-4, 3.0, 4.0])
            bearings = np.append(bearings, [0.1, 0.2, np.inf, 0.5])
            ids = np.append(ids, [5, 5, 5, -1])
        reports = []
        turn = (step.odometry[2] - previous[2] + np.pi) % (2.0 * np.pi) - np.pi
        midway = previous + 0.5 * np.append(step.odometry[:2] - previous[:2], turn)
        for slam in filters:
            if halves:
                slam.predict(previous, midway)
                slam.predict(midway, step.odometry)
            else:
                slam.predict(previous, step.odometry)
            reports.append(slam.update(ranges, bearings, ids, stamp=float(k)))
        previous = step.odometry
        numpy_report, numba_report = reports
        assert numpy_report.num_observations == numba_report.num_observations
        if k % 7 == 3:
            skipped = 4 if association == "known" else 3
            assert numpy_report.num_observations == len(step.ranges) + 4 - skipped
        np.testing.assert_array_equal(numpy_report.associated_ids, numba_report.associated_ids)
        np.testing.assert_array_equal(numpy_report.is_new, numba_report.is_new)
        assert numpy_report.resampled == numba_report.resampled
        resampled += numpy_report.resampled
        np.testing.assert_allclose(filters[0].poses, filters[1].poses, atol=1e-9, rtol=0)
        np.testing.assert_allclose(filters[0].log_weights, filters[1].log_weights, atol=1e-9,
                                   rtol=0)
    assert resampled > 0
    # The path history: the compiled reading writes each generation's poses itself.
    (numpy_stamps, numpy_path), (numba_stamps, numba_path) = (slam.best_path()
                                                              for slam in filters)
    np.testing.assert_array_equal(numpy_stamps, numba_stamps)
    np.testing.assert_allclose(numpy_path, numba_path, atol=1e-9, rtol=0)
    for m in range(0, base.num_particles, 7):
        # Same landmarks (creations and removals), same keys, same estimates.
        numpy_map, numba_map = (slam.particle_map(m) for slam in filters)
        order = [np.argsort(keys) for keys in (numpy_map[4], numba_map[4])]
        for a, b in zip(numpy_map, numba_map):
            np.testing.assert_allclose(a[order[0]], b[order[1]], atol=1e-9, rtol=0)


@needs_numba
def test_compiled_systematic_resampling_draws_the_numpy_indices():
    """Same weights and generator state: the same indices as ``systematic_resample``, also
    with degenerate weights (one particle holds all, zeros, ties at the pointers)."""
    from fastslam_ros.core import compiled as kernels
    rng = np.random.default_rng(5)
    cases = [rng.gamma(0.3, size=count) for count in (1, 7, 100, 1000) for _ in range(20)]
    cases += [np.eye(50)[17], np.full(64, 1.0), np.repeat([0.0, 1.0], 40)]
    for weights in cases:
        weights = weights / weights.sum()
        seed = int(rng.integers(1 << 31))
        expected = systematic_resample(weights, np.random.default_rng(seed))
        got, _, _ = kernels.resample_poses(weights, np.random.default_rng(seed),
                                           np.zeros((len(weights), 3)), 0)
        np.testing.assert_array_equal(got, expected)


@needs_numba
def test_compiled_take_matches_the_working_set_take():
    """Resampling the working set: every array equal to ``WorkingSet.take``'s, in fresh
    arrays (the source is left as it was)."""
    from fastslam_ros.core import compiled as kernels
    rng = np.random.default_rng(2)
    particles, width = 40, 9
    ws = WorkingSet(row=rng.integers(-1, 50, (particles, width)),
                    slot=rng.integers(0, 8, (particles, width)),
                    block=rng.integers(-1, 4, (particles, width)),
                    columns=np.broadcast_to(np.arange(4), (particles, 4)),
                    state=rng.normal(size=(particles, width, 6)),
                    ident=rng.integers(-1, 99, (particles, width, 2)),
                    valid=rng.random((particles, width)) < 0.5,
                    dirty=rng.random((particles, width)) < 0.5,
                    is_new=rng.random((particles, width)) < 0.5, first_new_slot=6)
    before = {name: np.copy(getattr(ws, name)) for name in vars(ws) if name != "first_new_slot"}
    indices = np.sort(rng.integers(0, particles, particles))
    expected, got = ws.take(indices), kernels.take(ws, indices)
    assert got.first_new_slot == expected.first_new_slot
    for name, original in before.items():
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name))
        np.testing.assert_array_equal(getattr(ws, name), original)
        assert not np.shares_memory(getattr(got, name), getattr(ws, name))


@needs_numba
def test_in_place_reindex_matches_the_working_set_take():
    """The working set reindexed in place after resampling (systematic draws: sorted indices,
    also compositions of them and collapses onto one particle; other indices are copied)
    holds what ``WorkingSet.take`` gives, the free columns left empty as gathered."""
    from fastslam_ros.core import compiled as kernels
    rng = np.random.default_rng(8)
    for particles in (1, 7, 60):
        store = LandmarkStore(particles, 5.0)
        ws = store.gather(np.full((particles, 0), -1, np.int64), 12)
        existing = 7
        ws.first_new_slot = existing
        used = slice(0, existing)
        ws.row[:, used] = rng.integers(-1, 50, (particles, existing))
        ws.slot[:, used] = rng.integers(0, 8, (particles, existing))
        ws.block[:, used] = rng.integers(-1, 4, (particles, existing))
        ws.state[:, used] = rng.normal(size=(particles, existing, 6))
        ws.ident[:, used] = rng.integers(-1, 99, (particles, existing, 2))
        for name in ("valid", "dirty", "is_new"):
            getattr(ws, name)[:, used] = rng.random((particles, existing)) < 0.5
        for draw in range(12):
            indices = (np.sort(rng.integers(0, particles, particles)) if draw % 4 < 2
                       else np.full(particles, int(rng.integers(particles))) if draw % 4 == 2
                       else rng.permutation(particles))
            expected = ws.take(indices)
            got = kernels.reindex(ws, indices)
            assert got.first_new_slot == expected.first_new_slot
            for name in vars(expected):
                np.testing.assert_array_equal(getattr(got, name), getattr(expected, name))
            ws = got


@needs_numba
def test_compiled_resampling_of_the_poses_matches_numpy():
    """``resample_poses``: the indices of ``systematic_resample`` on the same draw, the poses
    they pick and the first copy of the given particle (-1 when it has none)."""
    from fastslam_ros.core import compiled as kernels
    rng = np.random.default_rng(6)
    for count in (1, 7, 100, 1000):
        for _ in range(10):
            weights = rng.gamma(0.3, size=count)
            weights /= weights.sum()
            poses = rng.normal(size=(count, 3))
            best = int(rng.integers(count))
            seed = int(rng.integers(1 << 31))
            expected = systematic_resample(weights, np.random.default_rng(seed))
            indices, moved, copy = kernels.resample_poses(
                weights, np.random.default_rng(seed), poses, best)
            np.testing.assert_array_equal(indices, expected)
            np.testing.assert_array_equal(moved, poses[expected])
            copies = (expected == best).nonzero()[0]
            assert copy == (copies[0] if len(copies) else -1)


@needs_numba
def test_compiled_path_pruning_keeps_the_numpy_history():
    """The path history pruned by the compiled kernels holds the same generations, parents,
    poses and chain as the numpy one, through sorted, unsorted and collapsing resamplings."""
    from fastslam_ros.core import compiled as kernels
    from fastslam_ros.core.path_history import PathHistory
    for particles in (1, 6, 50):
        rng = np.random.default_rng(particles)
        histories = [PathHistory(particles, prune_every=4, chain_capacity=64,
                                 prune=backend) for backend in (None, kernels.prune)]
        for step in range(300):
            poses = rng.normal(size=(particles, 3))
            draw = rng.random()
            indices = (np.sort(rng.integers(0, particles, particles)) if draw < 0.4
                       else rng.integers(0, particles, particles) if draw < 0.5
                       else np.full(particles, int(rng.integers(particles))) if draw < 0.6
                       else None)
            for history in histories:
                history.record(float(step), poses)
                if indices is not None:
                    history.resample(indices)
            reference, compiled = histories
            np.testing.assert_array_equal(compiled.leaf, reference.leaf)
            generations = compiled.generations(), reference.generations()
            assert len(generations[0]) == len(generations[1])
            for (stamp, parents, kept), (stamp_ref, parents_ref, kept_ref) in zip(*generations):
                assert stamp == stamp_ref
                np.testing.assert_array_equal(parents, parents_ref)
                np.testing.assert_array_equal(kept, kept_ref)
            np.testing.assert_array_equal(compiled._chain_poses, reference._chain_poses)
            np.testing.assert_array_equal(compiled._chain_stamps, reference._chain_stamps)


@needs_numba
def test_compiled_gather_matches_the_store_gather():
    """The working set of some cells of a shared store with copy-on-write blocks, full cells
    and particles without a landmark there: equal to ``LandmarkStore.gather``'s."""
    from fastslam_ros.core import compiled as kernels
    world = make_world(seed=4, num_landmarks=40, extent=20.0, num_steps=40, max_range=6.0)
    slam = FastSLAM(FastSLAMConfig(num_particles=30, association="ml", max_range=6.0,
                                   cell_size=3.0, backend="numpy"),
                    rng=np.random.default_rng(1), initial_pose=world.steps[0].truth)
    previous = world.steps[0].odometry
    for k, step in enumerate(world.steps[1:]):
        slam.predict(previous, step.odometry)
        previous = step.odometry
        slam.update(step.ranges, step.bearings, stamp=float(k))
    slam.flush()
    store = slam.landmarks
    store.resample(np.sort(np.random.default_rng(3).integers(0, 30, 30)))
    rng = np.random.default_rng(6)
    for _ in range(5):
        columns = rng.integers(-1, store.num_cells, (30, 6))
        expected = store.gather(columns, 4)
        # On the calling thread and in chunks of particles on two threads.
        for threads in (1, 2):
            got = kernels.landmark_store._gather(store, columns, 4, threads)
            assert got.first_new_slot == expected.first_new_slot > 0
            for name in vars(expected):
                np.testing.assert_array_equal(getattr(got, name), getattr(expected, name))
    # One particle's stored map, read back compiled: the same records in the same order.
    for particle in range(30):
        rows = store.tables.row(particle, store.num_cells)
        rows[rng.integers(0, store.num_cells, 3)] = -1
        state, ident = kernels.block_records(rows, store.occupied, store.state, store.ident)
        kept = rows[rows >= 0]
        mask = store.occupied[kept]
        assert len(state) == mask.sum()
        np.testing.assert_array_equal(state, store.state[kept][mask])
        np.testing.assert_array_equal(ident, store.ident[kept][mask])


@needs_numba
def test_compiled_write_back_leaves_the_store_of_the_numpy_one():
    """Random insertions (overflowing blocks), resamplings, updates and removals with known
    labels: the compiled write-back gives the numpy store's pool, tables and counts."""
    rng = np.random.default_rng(8)
    count = 6
    stores = [LandmarkStore(count, 5.0, capacity=3),
              LandmarkStore(count, 5.0, capacity=3, kernels=StoreKernels.compiled())]
    for step in range(80):
        points = rng.uniform(-25.0, 25.0, (3, 2))
        particle, labels = int(rng.integers(0, count)), 10 * step + np.arange(3)
        indices = np.sort(rng.integers(0, count, count))
        low, change = rng.uniform(-25.0, 15.0, 2), rng.random(64)
        for store in stores:
            ws = store.gather(np.full((count, 0), -1, np.int64), 3)
            ws.mean[particle], ws.cov[particle] = points, (0.1, 0.0, 0.1)
            ws.label[particle] = labels
            ws.valid[particle] = ws.is_new[particle] = True
            store.scatter(ws, track_labels=True)
            store.resample(indices)
            edit_box(store, low, change, 0.4, 0.1)
        for name in ("state", "ident", "occupied", "refcount", "table", "label_column"):
            np.testing.assert_array_equal(getattr(stores[1], name), getattr(stores[0], name))
    for store in stores:
        store.apply_resampling()
    for name in ("table", "refcount", "label_column"):
        np.testing.assert_array_equal(getattr(stores[1], name), getattr(stores[0], name))


@needs_numba
def test_compiled_write_back_reads_through_a_pending_resampling():
    """A working set written back with a resampling not applied to it (particle m's entries
    are particle ``order[m]``'s, some copied twice, none of some): the compiled write-back,
    which reads through ``order``, leaves the store of the numpy one, which applies it first;
    copies of a keyless new landmark get a key each."""
    rng = np.random.default_rng(5)
    count = 8
    stores = [LandmarkStore(count, 5.0, capacity=3),
              LandmarkStore(count, 5.0, capacity=3, kernels=StoreKernels.compiled())]
    keyless = 0
    for step in range(60):
        low = rng.uniform(-20.0, 10.0, 2)
        order = np.sort(rng.integers(0, count, count))
        creators = rng.random(count) < 0.5
        points = rng.uniform(-20.0, 20.0, (count, 2, 2))
        keys = np.where(rng.random((count, 2)) < 0.5, -1,
                        10 ** 6 + 100 * step + np.arange(2 * count).reshape(count, 2))
        shuffle = np.sort(rng.integers(0, count, count))
        change = rng.random(1000)
        for store in stores:
            columns = store.columns_in_box(low, low + 10.0)
            ws = store.gather(np.broadcast_to(columns, (count, len(columns))), 2)
            particle, slot = ws.valid.nonzero()
            moved = change[:len(particle)] < 0.4
            ws.mean[particle[moved], slot[moved]] += 0.01
            ws.dirty[particle[moved], slot[moved]] = True
            gone = change[:len(particle)] < 0.1
            ws.valid[particle[gone], slot[gone]] = False
            new = slice(ws.first_new_slot, None)
            ws.mean[creators, new] = points[creators]
            ws.cov[creators, new] = (0.1, 0.0, 0.1)
            ws.key[creators, new] = keys[creators]
            ws.valid[creators, new] = ws.is_new[creators, new] = True
            # Resampled as the filter does it: the store's tables now, the working set's
            # entries pending.
            store.resample(order)
            store.scatter(ws, track_labels=False, order=order)
            if step % 3 == 0:
                store.resample(shuffle)
        keyless += int((keys[order][creators[order]] < 0).sum())
        for name in ("state", "ident", "occupied", "refcount", "table", "next_key"):
            np.testing.assert_array_equal(getattr(stores[1], name), getattr(stores[0], name))
    assert keyless > 0
    for particle in range(count):
        keys = stores[1].particle_map(particle)[4]
        assert len(np.unique(keys)) == len(keys)


@needs_numba
def test_compiled_odometry_prior_matches_the_numpy_steps():
    """``kernels.advance_mean`` and ``propagate_cov`` against ``from_delta``,
    ``control_variances`` and ``propagate_gaussian``: forward, backward, turning in place,
    with random-walk terms."""
    from fastslam_ros.core import compiled as kernels
    from fastslam_ros.core.motion import OdometryControl, control_variances, propagate_gaussian
    from fastslam_ros.core.observation import SensorOffset
    rng = np.random.default_rng(4)
    config = FastSLAMConfig(alpha1=0.02, alpha2=0.001, alpha3=0.01, alpha4=0.005,
                            rotation_variance_per_radian=1e-3, rotation_variance_per_meter=2e-4,
                            translation_variance_per_meter=3e-3,
                            translation_variance_per_radian=1e-4).validate()
    settings = kernels.reading_settings(config, SensorOffset(0.0, 0.0, 0.0), -5.0, -np.inf,
                                        10.0)
    poses = rng.normal(0.0, 2.0, (20, 3))
    prior = None
    for delta in ([0.5, 0.02, 0.01], [-0.4, 0.01, -0.02], [0.0, 0.0, 0.3], [1e-12, 0.0, 0.0],
                  [0.1, -0.3, 3.0]):
        delta = np.array(delta)
        control = OdometryControl.from_delta(delta)
        variances = control_variances(control, (config.alpha1, config.alpha2, config.alpha3,
                                                config.alpha4),
                                      config.min_translation_sigma, config.min_rotation_sigma,
                                      (1e-3, 2e-4, 3e-3, 1e-4))
        mean, cov = prior if prior is not None else (poses, np.zeros((20, 3, 3)))
        expected = propagate_gaussian(mean, cov, control, variances)
        moved, widest, turn, motion = kernels.advance_mean(prior, poses, delta, settings)
        got = (moved, kernels.propagate_cov(turn, None if prior is None else prior[1], motion))
        for a, b in zip(got, expected):
            np.testing.assert_allclose(a, b, rtol=0.0, atol=1e-12)
        assert widest == expected[1][:, 2, 2].max()
        prior = got
    # A NaN heading variance makes the widest NaN, as numpy's max does (the filter then
    # neither samples the prior nor draws: both backends keep one random stream).
    cov = np.zeros((20, 3, 3))
    cov[7, 2, 2] = np.nan
    _, widest, _, _ = kernels.advance_mean((poses, cov), poses, np.array([0.1, 0.0, 0.0]),
                                        settings)
    assert np.isnan(widest)


def test_core_runs_without_numba():
    """numba hidden: ``auto`` runs numpy, ``numba`` fails naming the parameter."""
    script = (
        "import sys; sys.modules['numba'] = None\n"
        "from fastslam_ros.core import FastSLAM, FastSLAMConfig\n"
        "slam = FastSLAM(FastSLAMConfig(num_particles=5, seed=1))\n"
        "slam.update([2.0], [0.1])\n"
        "assert slam.backend == 'numpy' and 'fastslam_ros.core.compiled' not in sys.modules\n"
        "try:\n"
        "    FastSLAMConfig(backend='numba').validate()\n"
        "except ValueError as error:\n"
        "    assert str(error).startswith('backend:'), error\n"
        "else:\n"
        "    raise AssertionError('backend numba accepted without numba')\n")
    subprocess.run([sys.executable, "-c", script], check=True, cwd=REPO_ROOT,
                   env={"PYTHONPATH": str(REPO_ROOT), "PATH": "/usr/bin:/bin"})


@needs_numba
@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs /proc as an unwritable folder")
def test_compiled_backend_runs_with_an_unwritable_cache_folder():
    """A cache folder that cannot be written (as on a read-only install): numba falls back
    to its next cache location, and the filter still runs compiled."""
    script = (
        "from fastslam_ros.core import FastSLAM, FastSLAMConfig\n"
        "slam = FastSLAM(FastSLAMConfig(num_particles=5, seed=1, backend='numba'))\n"
        "slam.update([2.0], [0.1])\n"
        "assert slam.backend == 'numba'\n")
    subprocess.run([sys.executable, "-c", script], check=True, cwd=REPO_ROOT,
                   env={**os.environ, "PYTHONPATH": str(REPO_ROOT),
                        "NUMBA_CACHE_DIR": "/proc/self/unwritable-numba-cache"})


@needs_numba
@pytest.mark.parametrize("particles", [50, 600])
def test_no_kernel_compiles_on_a_reading_after_warm_up(particles):
    """Compilation never lands on a message: in a fresh interpreter, after ``warm_up``, a run
    of every association rule (on the calling thread, and split over two threads from
    PARALLEL_MIN_PARTICLES on) adds no compiled signature to any kernel."""
    script = (
        "from numba.core.registry import CPUDispatcher\n"
        "from fastslam_ros.core import FastSLAM, FastSLAMConfig, compiled as kernels\n"
        "from fastslam_ros.tools.simulation.synthetic import make_world\n"
        "kernels.warm_up()\n"
        "kernels.crew.threads_for = lambda m: 1 if m < kernels.PARALLEL_MIN_PARTICLES else 2\n"
        "import sys\n"
        "def compiled():\n"
        "    return {f'{module}.{name}': len(value.signatures)\n"
        "            for module in list(sys.modules) if module.startswith(kernels.__name__)\n"
        "            for name, value in vars(sys.modules[module]).items()\n"
        "            if isinstance(value, CPUDispatcher)}\n"
        "before = compiled()\n"
        "world = make_world(seed=3, num_landmarks=20, extent=24.0, num_steps=15, max_range=9.0)\n"
        "for association in ('known', 'ml', 'monte_carlo', 'two_gate'):\n"
        "    for algorithm in ('fastslam1', 'fastslam2'):\n"
        f"        slam = FastSLAM(FastSLAMConfig(num_particles={particles}, algorithm=algorithm,\n"
        "                        association=association, max_range=9.0, seed=1,\n"
        "                        backend='numba', resample_threshold=1.0),\n"
        "                        initial_pose=world.steps[0].truth)\n"
        "        previous = world.steps[0].odometry\n"
        "        for step in world.steps[1:]:\n"
        "            slam.predict(previous, step.odometry)\n"
        "            previous = step.odometry\n"
        "            slam.update(step.ranges, step.bearings, step.ids)\n"
        "after = compiled()\n"
        "grown = {name: (before[name], count) for name, count in after.items()\n"
        "         if count != before.get(name)}\n"
        "assert not grown, grown\n")
    subprocess.run([sys.executable, "-c", script], check=True, cwd=REPO_ROOT,
                   env={**os.environ, "PYTHONPATH": str(REPO_ROOT)})


@needs_numba
def test_existence_from_a_detection_probability_is_the_same_on_both_backends():
    """tau+ and tau- derived from P_D and the clutter rate reach the compiled reading as the
    numpy one uses them: the same removals, the same runs."""
    assert_same_run("fastslam2", "ml", detection_probability=0.85, clutter_rate=0.5)


@needs_numba
def test_crew_runs_each_job_and_raises_a_workers_error_here():
    """The chunked gather's hand-off: every job runs once (the first on this thread), and an
    exception on a worker is raised on the calling thread."""
    from fastslam_ros.core import compiled as kernels

    crew = kernels.crew._Crew(1)
    done = []
    try:
        crew.run_each(lambda x: done.append(x), [(0,), (1,)])
        assert sorted(done) == [0, 1]

        def failing(x):
            if x == 1:
                raise RuntimeError("worker failed")

        with pytest.raises(RuntimeError, match="worker failed"):
            crew.run_each(failing, [(0,), (1,)])
        with pytest.raises(ValueError, match="3 jobs"):
            crew.run_each(failing, [(0,), (0,), (0,)])
    finally:
        crew.stop()


def test_a_changed_twin_drops_the_whole_packages_cache(tmp_path):
    """numba keys a cached kernel on its own file, yet a kernel holds the code of the twins it
    calls: any source change of the package removes every cached kernel beside it."""
    pytest.importorskip("numba")
    from fastslam_ros.core.compiled.jit import drop_stale_cache
    (tmp_path / "caller.py").write_text("x = 1\n")
    (tmp_path / "callee.py").write_text("y = 1\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    made = [cache / "caller.f-1.py311.nbi", cache / "caller.f-1.py311.1.nbc"]
    for path in made:
        path.write_bytes(b"compiled")
    assert drop_stale_cache(tmp_path) and not any(path.exists() for path in made)
    for path in made:
        path.write_bytes(b"compiled")
    assert not drop_stale_cache(tmp_path) and all(path.exists() for path in made)
    (tmp_path / "callee.py").write_text("y = 2\n")  # the callee changed, the caller did not
    assert drop_stale_cache(tmp_path) and not any(path.exists() for path in made)
