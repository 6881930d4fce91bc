# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Conversions for the landmark extractor: LaserScan in, landmark cloud and markers out.

Pure functions, no node code. The reader uses message attributes only, so it accepts rclpy
messages and ``rosbags`` look-alikes. The cloud carries the input layout ``fastslam_node``
reads (x y z float32, id int32 = -1: unknown) plus ``radius`` and ``intensity`` (float32).
"""
from __future__ import annotations

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


def read_scan(msg, max_beams: int | None = None) -> RawScan:
    """``sensor_msgs/LaserScan`` -> ``RawScan``, its geometry checked
    (``ros_io.scan_geometry``; ``OversizedError`` beyond ``max_beams``), ranges as sent (REP
    117 meanings kept); intensities must be none or one per beam (``MalformedScanError``)."""
    geometry = ros_io.scan_geometry(msg, max_beams)
    ranges = np.asarray(msg.ranges, dtype=float)
    intensities = np.asarray(msg.intensities, dtype=float)
    if intensities.size not in (0, ranges.size):
        raise ros_io.MalformedScanError(f"{intensities.size} intensities for {ranges.size} beams")
    return RawScan(ranges, geometry.angle_min, geometry.angle_increment, geometry.range_min,
                   geometry.range_max, intensities, geometry.time_increment)


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
