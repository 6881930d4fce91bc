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

from fastslam_ros import ros_io, ros_markers
from fastslam_ros.core import geometry
from fastslam_ros.people.report import PeopleEstimate
from fastslam_ros.people.detection import Scan
from fastslam_ros.people.grid import OccupancyMap

PERSON_NAMESPACE = "person"
PERSON_HEIGHT = 1.7
PERSON_DIAMETER = 0.4


class MalformedMapError(ValueError):
    """An OccupancyGrid or map file that cannot be read as a grid, or one with no free cell."""


def read_scan(msg, max_beams: int | None = None) -> Scan:
    """``sensor_msgs/LaserScan`` -> ``Scan`` (REP 117), its geometry checked
    (``ros_io.scan_geometry``): +inf is nothing within range_max (kept as inf: the beam saw
    free space); NaN, -inf and every range outside [range_min, range_max] carry no evidence at
    all (NaN in the Scan)."""
    geometry = ros_io.scan_geometry(msg, max_beams)
    ranges = np.asarray(msg.ranges, dtype=float)
    with np.errstate(invalid="ignore"):
        evidence = (ranges >= geometry.range_min) & (ranges <= geometry.range_max)
    ranges = np.where(evidence | (ranges == math.inf), ranges, math.nan)
    return Scan(ranges, geometry.angle_min, geometry.angle_increment, geometry.range_max,
                geometry.time_increment)


def _check_origin(x: float, y: float, yaw: float) -> None:
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
        raise MalformedMapError(f"origin ({x}, {y}, {yaw}) is not finite")
    if abs(yaw) > 1e-6:
        raise MalformedMapError(f"origin yaw {yaw} rad: rotated maps are not supported")


def _check_resolution(resolution: float) -> None:
    if not (math.isfinite(resolution) and resolution > 0.0):
        raise MalformedMapError(f"resolution {resolution} is not a cell size (> 0 m)")


def _check_cells(width: int, height: int, max_cells: int | None) -> None:
    if max_cells is not None and width * height > max_cells:
        raise ros_io.OversizedError(f"{width} x {height} cells (max_map_cells {max_cells})")


def _usable(grid: OccupancyMap) -> OccupancyMap:
    """The grid, or ``MalformedMapError`` when it has no free cell to be in."""
    if not grid.free.any():
        raise MalformedMapError(f"no free cell in {grid.shape[1]} x {grid.shape[0]} cells")
    return grid


def read_occupancy_grid(msg, max_distance: float, max_cells: int | None = None
                        ) -> OccupancyMap:
    """``nav_msgs/OccupancyGrid`` -> ``OccupancyMap`` (likelihood field clipped at
    ``max_distance`` m); ``MalformedMapError`` for a grid that cannot be used (no free cell
    included), ``ros_io.OversizedError`` beyond ``max_cells`` (checked before the cells are
    read)."""
    info = msg.info
    width, height, resolution = int(info.width), int(info.height), float(info.resolution)
    _check_cells(width, height, max_cells)
    if width <= 0 or height <= 0 or len(msg.data) != width * height:
        raise MalformedMapError(f"{len(msg.data)} cells for {width} x {height}")
    _check_resolution(resolution)
    origin = info.origin
    _check_origin(origin.position.x, origin.position.y,
                  ros_io.quaternion_to_yaw(origin.orientation))
    data = np.asarray(msg.data, dtype=np.int16)
    return _usable(OccupancyMap.from_occupancy(data.reshape(height, width), resolution,
                                               (origin.position.x, origin.position.y),
                                               max_distance))


def _threshold(description: dict, name: str, default: float) -> float:
    """A nav2 threshold in [0, 1] (``MalformedMapError`` naming it otherwise)."""
    value = description.get(name, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not 0.0 <= value <= 1.0:
        raise MalformedMapError(f"{name} {value!r} is not a number in [0, 1]")
    return float(value)


def load_map_file(path: str | Path, max_distance: float, max_cells: int | None = None
                  ) -> OccupancyMap:
    """A nav2 map (YAML with image, resolution, origin, negate, occupied_thresh, free_thresh;
    trinary or scale mode) as an ``OccupancyMap``; ``MalformedMapError`` (or
    ``ros_io.OversizedError``) naming what cannot be used."""
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
    _check_resolution(resolution)
    _check_origin(x, y, yaw)
    occupied_threshold = _threshold(description, "occupied_thresh", 0.65)
    free_threshold = _threshold(description, "free_thresh", 0.25)
    negate = description.get("negate", 0)
    if negate not in (0, 1):  # True and False are 1 and 0
        raise MalformedMapError(f"negate {negate!r} is not 0 or 1")
    from PIL import Image
    try:
        with Image.open(image_path) as image:
            _check_cells(*image.size, max_cells)
            pixels = np.asarray(image.convert("L"), dtype=float)
    except (OSError, Image.DecompressionBombError) as error:
        raise MalformedMapError(f"{image_path}: {error}") from None
    occupancy = (pixels / 255.0) if negate else (255.0 - pixels) / 255.0
    occupied = occupancy > occupied_threshold
    free = occupancy < free_threshold
    # image row 0 is the top of the map; grid row 0 is its bottom
    return _usable(OccupancyMap(occupied[::-1], free[::-1], resolution, (x, y), max_distance))


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
        ellipse = ros_markers.ellipse_marker(header, key, (x, y, float(angles[index])),
                                        float(major[index]), float(minor[index]),
                                        ColorRGBA(r=1.0, g=0.8, b=0.2, a=0.4))
        label = ros_markers.label_marker(
            header, key, (x, y, PERSON_HEIGHT + ros_markers.LABEL_LIFT), str(key))
        markers += [body, ellipse, label]
    markers += ros_markers.delete_markers(header, removed_keys, (
        PERSON_NAMESPACE, ros_markers.ELLIPSE_NAMESPACE, ros_markers.LABEL_NAMESPACE))
    return MarkerArray(markers=markers)
