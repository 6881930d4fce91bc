# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""ROS-free landmark extraction from planar laser scans (numpy): poles, trunks and reflectors."""
from .extract import Extraction, Landmarks, extract_landmarks, reflector_threshold
from .scan import RawScan
from .settings import DETECTORS, ExtractorSettings

__all__ = ["DETECTORS", "ExtractorSettings", "Extraction", "Landmarks", "RawScan",
           "extract_landmarks", "reflector_threshold"]
