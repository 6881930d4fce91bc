# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Compiled (numba) twins of the numpy core, for the per-reading math of ``FastSLAM``.

The numpy core spends most of a reading at moderate M on call overhead (hundreds of small array
operations whatever M is). Here one compiled call, ``update_reading``, does the whole reading
for every particle. Each module twins the numpy module of the same name (``association``,
``proposal``, ``landmark_ekf``, ``motion``, ``resampling``, ``landmark_store``,
``path_history``) and imports its constants from it; ``reading`` drives a reading, ``crew``
holds its threads, ``settings`` holds the configuration as typed records, ``records`` the named
tuples of arrays the kernels pass, ``warm_up`` compiles everything once.
The results are those of the numpy modules: the same discrete choices and floats equal to
round-off, on the same random draws (drawn by the caller from its ``numpy.random.Generator``
in the numpy path's order); ``test/test_backends.py`` runs each pair on the same draws.

numba is optional (``pip install fastslam_ros[fast]``); importing this package without it
raises ImportError, and the filter then runs on numpy (``FastSLAMConfig.backend``). The
compiled code is cached beside these files when their folder is writable and in numba's user
cache folder otherwise (``NUMBA_CACHE_DIR`` overrides both), so a read-only install works.

numba keys each cached kernel on its own file only, while a kernel carries the code of the
kernels it calls from the other twins: ``jit.drop_stale_cache`` (run on import) removes the
package's cache whenever any of its sources changed, so an edited twin is never run in its old
form inside another one.

What follows is the whole interface the core calls.
"""
from .crew import PARALLEL_MIN_PARTICLES, set_threads, splits
from .landmark_store import (block_records, claim, claim_plan, dirty_pairs, gather,
                             insertion_pairs, new_entries, place, write_back)
from .motion import advance_mean, propagate_cov, sample_motion
from .path_history import prune
from .proposal import sample_pose
from .reading import pose_box, update_reading, usable_observations
from .records import Draws, Particles
from .resampling import reindex, resample_poses, take
from .settings import MODE_CODES, ReadingSettings, reading_settings
from .warm_up import warm_up

__all__ = ["PARALLEL_MIN_PARTICLES", "set_threads", "splits", "block_records", "claim",
           "claim_plan", "dirty_pairs", "gather", "insertion_pairs", "new_entries", "place",
           "write_back", "advance_mean", "propagate_cov", "sample_motion", "prune", "sample_pose",
           "pose_box", "update_reading", "usable_observations", "Draws", "Particles", "reindex",
           "resample_poses", "take", "MODE_CODES", "ReadingSettings", "reading_settings",
           "warm_up"]
