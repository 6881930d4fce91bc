# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The backends of ``FastSLAM``, each one record of the functions the filter calls, chosen once
(``choose_backend``): numpy (the reference, here) or the compiled twins (``core.compiled``,
called by ``backend_compiled.py``), which give the same results on the same random draws.
``FastSLAM`` calls ``self._backend.<function>`` and never asks which backend runs."""
from __future__ import annotations

import sys
from functools import partial
from typing import Callable, NamedTuple

import numpy as np

from .config import FastSLAMConfig, numba_available
from .motion import OdometryControl, control_variances, propagate_gaussian, sample_motion
from .proposal import sample_pose
from .reading import NumpyReading
from .resampling import RESAMPLERS


class Backend(NamedTuple):
    """A backend's functions; those taking ``slam`` read and change the filter's state."""

    name: str
    """``numpy`` or ``numba`` (``FastSLAM.backend``)."""
    usable: Callable
    """(slam, ranges, bearings, labels) -> the usable observations and the largest range."""
    read: Callable
    """(slam, ws, mean, cov, ranges, bearings, labels, reach, stamp) -> ``ReadingOutcome``:
    steps 2 to 5 of a reading."""
    advance_prior: Callable
    """(slam, delta) -> the widest heading variance: FastSLAM 2.0's Gaussian prior moved by
    the odometry ``delta`` (dx, dy, dtheta)."""
    propagate_cov: Callable | None
    """(turn, cov, motion) -> the covariance ``advance_prior`` left to the next reading
    (``FastSLAM._deferred``); None: this backend leaves none."""
    sample_motion: Callable
    """(poses, control, variances, normals) -> FastSLAM 1.0's poses moved by the control."""
    sample_pose: Callable
    """(mean, cov, normals) -> poses drawn from N(mean, cov)."""
    resample: Callable
    """(weights, rng, poses, best) -> (indices, resampled poses, first copy of ``best`` or
    -1), by ``FastSLAMConfig.resampling``."""
    splits: Callable
    """(num_particles) -> whether a reading runs over threads (then its chunks make a
    pending resampling's working-set copy: ``WorkingSetCache.for_reading(lazy=)``)."""
    settings: object
    """The compiled reading's settings (``compiled.ReadingSettings``), None on numpy."""
    store_kernels: object
    """The compiled twins ``LandmarkStore`` runs its gather and write-back on
    (``landmark_store.StoreKernels``), None: numpy."""
    prune: Callable | None
    """``PathHistory``'s compiled pruning (``compiled.prune``), None: numpy."""


def wants_compiled(backend: str) -> bool:
    """Whether ``FastSLAMConfig.backend`` = ``backend`` runs the compiled twins."""
    return backend == "numba" or (backend == "auto" and numba_available())


def kernels_pending(backend: str) -> bool:
    """Whether a filter built now with ``backend`` first compiles the kernels (or loads them from
    numba's cache): about 45 s on a first start, so a node says so before."""
    if not wants_compiled(backend):
        return False
    warm_up = sys.modules.get(f"{__package__}.compiled.warm_up")
    return warm_up is None or not getattr(warm_up, "_warm", False)


def choose_backend(config: FastSLAMConfig, offset, log_p0: float, log_outlier: float) -> Backend:
    """The backend ``config.backend`` asks for; the compiled one compiled (or loaded from
    numba's cache) now."""
    if wants_compiled(config.backend):
        from .backend_compiled import compiled_backend  # noqa: PLC0415 (numba needed)
        return compiled_backend(config, offset, log_p0, log_outlier)
    return Backend("numpy", NumpyReading._usable_numpy, NumpyReading._read_numpy,
                   advance_prior_numpy, None, sample_motion, sample_pose,
                   resample_numpy(RESAMPLERS[config.resampling]), _never_splits, None, None,
                   None)


def advance_prior_numpy(slam, delta) -> float:
    """The prior's mean and covariance moved by the odometry (``motion.propagate_gaussian``)."""
    config = slam.config
    control = OdometryControl.from_delta(delta)
    variances = control_variances(control, slam.alphas, config.min_translation_sigma,
                                  config.min_rotation_sigma, slam.linear_noise)
    prior = slam._settled_prior()
    mean, cov = prior if prior is not None else (
        slam.poses, np.zeros((slam.num_particles, 3, 3)))
    slam._set_prior(propagate_gaussian(mean, cov, control, variances))
    return slam._prior[1][:, 2, 2].max()


def resample_numpy(resampler: Callable) -> Callable:
    """``Backend.resample`` by ``resampler`` (``resampling.RESAMPLERS``)."""
    return partial(_resample_with, resampler)


def _resample_with(resampler: Callable, weights: np.ndarray, rng: np.random.Generator,
                   poses: np.ndarray, best: int):
    """(indices, resampled poses, first copy of ``best`` or -1) drawn by ``resampler``."""
    indices = resampler(weights, rng)
    copies = (indices == best).nonzero()[0]
    return indices, poses[indices], int(copies[0]) if len(copies) else -1


def _never_splits(num_particles: int) -> bool:
    """The numpy reading runs on one thread."""
    return False
