# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""ROS-free people tracking on a known map (numpy, scipy): the conditional particle filter."""
from .conditional_filter import PeopleTracker
from .detection import Scan
from .grid import OccupancyMap
from .report import PeopleEstimate, UpdateReport
from .settings import TrackerSettings

__all__ = ["OccupancyMap", "PeopleEstimate", "PeopleTracker", "Scan", "TrackerSettings",
           "UpdateReport"]
