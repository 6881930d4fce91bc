# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""ROS-free FastSLAM core: filter, models, association, resampling, map storage, in numpy, with
optional numba twins of the per-reading math in ``core/compiled`` (the ``fast`` extra)."""
from .config import FastSLAMConfig
from .fastslam import FastSLAM, LandmarkMap, UpdateReport
from .geometry import wrap_angle

__all__ = ["FastSLAM", "FastSLAMConfig", "LandmarkMap", "UpdateReport", "wrap_angle"]
