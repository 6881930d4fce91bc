# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""ROS-free FastSLAM core (numpy only): filter, models, association, resampling, map storage."""
from .config import FastSLAMConfig
from .fastslam import FastSLAM, LandmarkMap, UpdateReport
from .geometry import wrap_angle

__all__ = ["FastSLAM", "FastSLAMConfig", "LandmarkMap", "UpdateReport", "wrap_angle"]
