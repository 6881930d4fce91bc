# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Conversions for the people tracker: LaserScan, OccupancyGrid, nav2 map files, outputs.

Pure functions, no node code. Readers use message attributes only, so they accept rclpy
messages and ``rosbags`` look-alikes. Output clouds share the ``~/map_cloud`` layout of the SLAM
node (x y z float32, id int32, cov_xx cov_xy cov_yy existence float32).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml
from geometry_msgs.msg import Point
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from fastslam_ros import ros_io
from fastslam_ros.core import geometry
from fastslam_ros.people.conditional_filter import PeopleEstimate
from fastslam_ros.people.detection import Scan
from fastslam_ros.people.grid import OccupancyMap

PERSON_NAMESPACE = "person"
PERSON_HEIGHT = 1.7
PERSON_DIAMETER = 0.4


class MalformedScanError(ValueError):
    """A LaserScan whose geometry cannot be used (no beams, zero or non-finite increment)."""


class MalformedMapError(ValueError):
    """An OccupancyGrid or map file that cannot be read as a grid."""


def read_scan(msg) -> Scan:
    """``sensor_msgs/LaserScan`` -> ``Scan``; NaN and +-inf ranges are no return (REP 117)."""
    ranges = np.asarray(msg.ranges, dtype=float)
    increment, angle_min = float(msg.angle_increment), float(msg.angle_min)
    if ranges.size == 0:
        raise MalformedScanError("no beams")
    if not (math.isfinite(increment) and math.isfinite(angle_min)) or increment == 0.0:
        raise MalformedScanError(f"angle_min {angle_min} / angle_increment {increment} unusable")
    if abs(increment) * (ranges.size - 1) > 2.0 * math.pi + 1e-3:
        raise MalformedScanError(f"{ranges.size} beams of {increment} rad span more than a turn")
    range_max = float(msg.range_max) if math.isfinite(msg.range_max) and msg.range_max > 0 \
        else math.inf
    ranges = np.where(np.isfinite(ranges) & (ranges >= max(float(msg.range_min), 0.0)), ranges,
                      np.inf)
    return Scan(ranges, angle_min, increment, range_max)


def _check_origin(x: float, y: float, yaw: float) -> None:
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
        raise MalformedMapError(f"origin ({x}, {y}, {yaw}) is not finite")
    if abs(yaw) > 1e-6:
        raise MalformedMapError(f"origin yaw {yaw} rad: rotated maps are not supported")


def read_occupancy_grid(msg, max_distance: float) -> OccupancyMap:
    """``nav_msgs/OccupancyGrid`` -> ``OccupancyMap`` (likelihood field clipped at
    ``max_distance`` m)."""
    info = msg.info
    width, height, resolution = int(info.width), int(info.height), float(info.resolution)
    data = np.asarray(msg.data, dtype=np.int16)
    if width <= 0 or height <= 0 or data.size != width * height:
        raise MalformedMapError(f"{data.size} cells for {width} x {height}")
    if not (math.isfinite(resolution) and resolution > 0.0):
        raise MalformedMapError(f"resolution {resolution}")
    origin = info.origin
    _check_origin(origin.position.x, origin.position.y,
                  ros_io.quaternion_to_yaw(origin.orientation))
    return OccupancyMap.from_occupancy(data.reshape(height, width), resolution,
                                       (origin.position.x, origin.position.y), max_distance)


def load_map_file(path: str | Path, max_distance: float) -> OccupancyMap:
    """A nav2 map (YAML with image, resolution, origin, negate, occupied_thresh, free_thresh;
    trinary or scale mode) as an ``OccupancyMap``."""
    path = Path(path).expanduser()
    try:
        description = yaml.safe_load(path.read_text())
        image_path = Path(description["image"])
        resolution = float(description["resolution"])
        x, y, yaw = (float(v) for v in description["origin"])
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as error:
        raise MalformedMapError(f"{path}: not a nav2 map description ({error})") from None
    if not image_path.is_absolute():
        image_path = path.parent / image_path
    _check_origin(x, y, yaw)
    from PIL import Image
    try:
        with Image.open(image_path) as image:
            pixels = np.asarray(image.convert("L"), dtype=float)
    except OSError as error:
        raise MalformedMapError(f"{image_path}: {error}") from None
    occupancy = (pixels / 255.0) if description.get("negate", 0) else (255.0 - pixels) / 255.0
    occupied = occupancy > float(description.get("occupied_thresh", 0.65))
    free = occupancy < float(description.get("free_thresh", 0.25))
    # image row 0 is the top of the map; grid row 0 is its bottom
    return OccupancyMap(occupied[::-1], free[::-1], resolution, (x, y), max_distance)


def people_cloud(header: Header, people: PeopleEstimate) -> PointCloud2:
    """``~/people``: one point per person (stable id, covariance, existence)."""
    return ros_io.estimate_cloud(header, people.means, people.covariances, people.existence,
                                 people.keys)


def people_markers(header: Header, people: PeopleEstimate, removed_keys=()) -> MarkerArray:
    """A cylinder, a 2-sigma ellipse and an id label per person; DELETE for people gone."""
    markers = []
    if len(people.keys):
        major, minor, angles = geometry.ellipse_axes(people.covariances)
    for index, key in enumerate(people.keys.tolist()):
        x, y = float(people.means[index, 0]), float(people.means[index, 1])
        alpha = 0.2 + 0.7 * float(people.existence[index])
        body = Marker(header=header, ns=PERSON_NAMESPACE, id=key, type=Marker.CYLINDER,
                      action=Marker.ADD, color=ColorRGBA(r=1.0, g=0.5, b=0.1, a=alpha))
        body.pose.position = Point(x=x, y=y, z=0.5 * PERSON_HEIGHT)
        body.pose.orientation.w = 1.0
        body.scale.x = body.scale.y = PERSON_DIAMETER
        body.scale.z = PERSON_HEIGHT
        ellipse = ros_io.ellipse_marker(header, key, (x, y, float(angles[index])),
                                        float(major[index]), float(minor[index]),
                                        ColorRGBA(r=1.0, g=0.8, b=0.2, a=0.4))
        label = ros_io.label_marker(header, key, (x, y, PERSON_HEIGHT + ros_io.LABEL_LIFT),
                                    str(key))
        markers += [body, ellipse, label]
    markers += ros_io.delete_markers(header, removed_keys, (
        PERSON_NAMESPACE, ros_io.ELLIPSE_NAMESPACE, ros_io.LABEL_NAMESPACE))
    return MarkerArray(markers=markers)
