# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Conversions for the landmark extractor: LaserScan in, landmark cloud and markers out.

Pure functions, no node code. The reader uses message attributes only, so it accepts rclpy
messages and ``rosbags`` look-alikes. The cloud carries the input layout ``fastslam_node``
reads (x y z float32, id int32 = -1: unknown) plus ``radius`` and ``intensity`` (float32).
"""
from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import Point
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from fastslam_ros import ros_io, ros_markers
from fastslam_ros.extractor import Landmarks, RawScan

EXTRACTED_CLOUD_DTYPE = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<i4"),
                                  ("radius", "<f4"), ("intensity", "<f4")])
MARKER_NAMESPACE = "extracted"
MARKER_HEIGHT = 1.0
CIRCLE_COLOUR = ColorRGBA(r=0.2, g=0.8, b=0.2, a=0.8)
REFLECTOR_COLOUR = ColorRGBA(r=1.0, g=0.9, b=0.1, a=0.9)


class MalformedScanError(ValueError):
    """A LaserScan whose geometry cannot be used (no beams, a zero or non-finite increment,
    more than a turn, intensities neither empty nor one per beam)."""


def read_scan(msg) -> RawScan:
    """``sensor_msgs/LaserScan`` -> ``RawScan``, ranges as sent (REP 117 meanings kept), its
    ``time_increment`` too (a non-finite one is malformed)."""
    ranges = np.asarray(msg.ranges, dtype=float)
    intensities = np.asarray(msg.intensities, dtype=float)
    increment, angle_min = float(msg.angle_increment), float(msg.angle_min)
    if ranges.size == 0:
        raise MalformedScanError("no beams")
    if not (math.isfinite(increment) and math.isfinite(angle_min)) or increment == 0.0:
        raise MalformedScanError(f"angle_min {angle_min} / angle_increment {increment} unusable")
    if abs(increment) * (ranges.size - 1) > 2.0 * math.pi + 1e-3:
        raise MalformedScanError(f"{ranges.size} beams of {increment} rad span more than a turn")
    if intensities.size not in (0, ranges.size):
        raise MalformedScanError(f"{intensities.size} intensities for {ranges.size} beams")
    time_increment = float(msg.time_increment)
    if not math.isfinite(time_increment):
        raise MalformedScanError(f"time_increment {time_increment} is not finite")
    range_min = float(msg.range_min) if math.isfinite(msg.range_min) else 0.0
    range_max = float(msg.range_max) if math.isfinite(msg.range_max) and msg.range_max > 0 \
        else math.inf
    return RawScan(ranges, angle_min, increment, max(range_min, 0.0), range_max, intensities,
                   time_increment)


def landmark_cloud(header: Header, landmarks: Landmarks) -> PointCloud2:
    """The ``landmarks`` cloud: one point per landmark, id -1, radius and mean intensity."""
    array = np.zeros(len(landmarks), EXTRACTED_CLOUD_DTYPE)
    array["x"], array["y"], array["id"] = landmarks.x, landmarks.y, -1
    array["radius"], array["intensity"] = landmarks.radius, landmarks.intensity
    return ros_io.cloud_from_array(header, array)


def landmark_markers(header: Header, landmarks: Landmarks) -> MarkerArray:
    """``~/markers``: the previous landmarks deleted, a cylinder per landmark (its diameter;
    reflectors yellow, circles green)."""
    markers = [Marker(header=header, ns=MARKER_NAMESPACE, action=Marker.DELETEALL)]
    for index in range(len(landmarks)):
        marker = Marker(header=header, ns=MARKER_NAMESPACE, id=index, type=Marker.CYLINDER,
                        action=Marker.ADD,
                        color=REFLECTOR_COLOUR if landmarks.reflector[index] else CIRCLE_COLOUR)
        marker.pose.position = Point(x=float(landmarks.x[index]), y=float(landmarks.y[index]),
                                     z=0.5 * MARKER_HEIGHT)
        marker.pose.orientation.w = 1.0
        marker.scale.x = marker.scale.y = max(2.0 * float(landmarks.radius[index]),
                                              ros_markers.MIN_MARKER_SCALE)
        marker.scale.z = MARKER_HEIGHT
        markers.append(marker)
    return MarkerArray(markers=markers)
