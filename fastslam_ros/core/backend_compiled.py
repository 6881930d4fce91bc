# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The compiled backend of ``FastSLAM`` (``backend.Backend``): the functions it calls on the
numba twins of ``core/compiled/``, on the numpy backend's random draws in its order.
Imported only when ``backend.choose_backend`` chooses it (numba needed)."""
from __future__ import annotations

import numpy as np

from . import compiled
from .backend import Backend, resample_numpy
from .config import LOGODDS_MAX, FastSLAMConfig
from .landmark_store import StoreKernels, WorkingSet
from .observation import MIN_OBSERVATION_RANGE
from .reading import ReadingOutcome, UpdateReport
from .resampling import RESAMPLERS

_NO_DRAWS = np.zeros(0)
_NO_NORMALS = np.zeros((0, 3))


def compiled_backend(config: FastSLAMConfig, offset, log_p0: float,
                     log_outlier: float) -> Backend:
    """The compiled backend for ``config``, its kernels compiled (or loaded from numba's
    cache) now."""
    compiled.warm_up()
    resample = (compiled.resample_poses if config.resampling == "systematic"
                else resample_numpy(RESAMPLERS[config.resampling]))
    settings = compiled.reading_settings(config, offset, log_p0, log_outlier, LOGODDS_MAX)
    return Backend("numba", usable, read, advance_prior, compiled.propagate_cov,
                   compiled.sample_motion, compiled.sample_pose, resample, compiled.splits,
                   settings, StoreKernels.compiled(), compiled.prune)


def usable(slam, ranges: np.ndarray, bearings: np.ndarray, labels: np.ndarray):
    """``NumpyReading._usable_numpy`` in one compiled pass."""
    return compiled.usable_observations(ranges, bearings, labels,
                                        slam.config.association == "known",
                                        MIN_OBSERVATION_RANGE)


def read(slam, ws: WorkingSet, mean: np.ndarray, cov: np.ndarray | None, ranges: np.ndarray,
         bearings: np.ndarray, labels: np.ndarray, reach: float, stamp: float) -> ReadingOutcome:
    """``NumpyReading._read_numpy`` in one call (``compiled.update_reading``), on the numpy
    path's random draws in its order; a covariance left to this reading (``_deferred``) is
    propagated in its blocks."""
    config, count = slam.config, slam.num_particles
    motion = slam._deferred
    draws = (slam.rng.random(len(ranges) * count) if config.association == "monte_carlo"
             else _NO_DRAWS)
    propose = (cov is not None or motion is not None) and config.algorithm == "fastslam2"
    normals = slam.rng.standard_normal((count, 3)) if propose else _NO_NORMALS
    (associated_ids, is_new, poses, slam.log_weights, n_eff, underflow, best, columns, keys,
     finite, ws) = compiled.update_reading(
        ws, compiled.Particles(slam.poses, slam.log_weights, mean, cov),
        (ranges, bearings, labels), compiled.Draws(draws, normals), slam._backend.settings,
        reach, slam.landmarks.next_key, propose,
        slam.history.next_generation(), slam.working.pending, motion)
    slam.working.took(ws)
    if propose:
        slam._set_prior(None)
    slam.poses = poses
    slam.landmarks.next_key += keys
    slam.history.record(stamp, written=True)
    slam.num_underflows += int(underflow)
    report = UpdateReport(len(ranges), associated_ids, is_new, False, float(n_eff),
                          bool(underflow))
    return ReadingOutcome(report, int(best), int(columns), bool(finite))


def advance_prior(slam, delta) -> float:
    """``backend.advance_prior_numpy``'s mean (``compiled.advance_mean``), its covariance left
    to the next reading's blocks of particles (or to the first other use of the prior,
    ``FastSLAM._settled_prior``)."""
    prior = slam._settled_prior()
    moved, widest, turn, motion = compiled.advance_mean(prior, slam.poses, delta,
                                                        slam._backend.settings)
    slam._prior = (moved, None)
    slam._deferred = (turn, None if prior is None else prior[1], motion)
    return widest
