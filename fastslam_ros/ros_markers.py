# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Landmark markers for RViz: a 2-sigma ellipse and an id label per landmark, keyed by the
landmark's stable key, as rclpy messages or as the views a replay serializes directly."""
from __future__ import annotations

from typing import NamedTuple, Sequence

import numpy as np
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from fastslam_ros.core import geometry
from fastslam_ros.map_files import LandmarkMapLike
from fastslam_ros.ros_io import PoseView, QuaternionView, VectorView, fill_pose, planar_pose_view

ELLIPSE_NAMESPACE = "covariance"
LABEL_NAMESPACE = "id"
ELLIPSE_HEIGHT = 0.02
LABEL_HEIGHT = 0.3
LABEL_LIFT = 0.3
MIN_MARKER_SCALE = 1e-3
"""RViz refuses markers with a zero scale; a thinner object is drawn this thin instead (m)."""


def landmark_markers(header: Header, landmark_map: LandmarkMapLike,
                     removed_keys: Sequence[int] = ()) -> MarkerArray:
    """2-sigma ellipse (CYLINDER) and id label per landmark, DELETE for each removed key.

    Markers are keyed by the landmark's stable key, so an update replaces the previous marker
    of the same landmark and a removed landmark disappears from RViz.
    """
    return MarkerBuilder().build(header, landmark_map, removed_keys)


class MarkerBuilder:
    """Builds successive ``~/landmarks`` MarkerArrays, each holding the whole map.

    Only the markers of landmarks that changed since the previous message (mean, covariance,
    existence or id) are built again, with the new header; the others are reused, so a large
    map that barely changed is cheap to publish again. The reused markers are never modified.
    ``lean``: the landmarks' markers are ``MarkerView`` and the array a ``MarkerArrayView``
    (what a replay serializes directly; an rclpy Marker builds a dozen sub-messages).
    """

    def __init__(self, lean: bool = False) -> None:
        self.lean = lean
        self._cache: dict[int, tuple[list[float], list[Marker]]] = {}

    def build(self, header: Header, landmark_map: LandmarkMapLike,
              removed_keys: Sequence[int] = ()) -> MarkerArray:
        count = len(landmark_map.means)
        covariances = np.asarray(landmark_map.covariances).reshape(count, 4)
        rows = np.column_stack([landmark_map.means, covariances[:, [0, 1, 3]],
                                landmark_map.existence, landmark_map.ids]).tolist()
        keys = np.asarray(landmark_map.keys).tolist()
        changed = [index for index, (key, row) in enumerate(zip(keys, rows))
                   if (cached := self._cache.get(key)) is None or cached[0] != row]
        cache = {}
        if changed:
            changed_covariances = np.asarray(landmark_map.covariances)[changed]
            major, minor, angles = geometry.ellipse_axes(changed_covariances)
            for position, index in enumerate(changed):
                views = _landmark_views(header, keys[index], rows[index], float(major[position]),
                                        float(minor[position]), float(angles[position]))
                cache[keys[index]] = (rows[index], views if self.lean
                                      else [marker_from_view(view) for view in views])
        markers = []
        for key, row in zip(keys, rows):
            entry = cache.get(key) or self._cache[key]
            cache[key] = entry
            markers += entry[1]
        self._cache = cache
        markers += delete_markers(header, removed_keys, (ELLIPSE_NAMESPACE, LABEL_NAMESPACE))
        return MarkerArrayView(markers) if self.lean else MarkerArray(markers=markers)


class _Color(NamedTuple):
    r: float
    g: float
    b: float
    a: float


class _Duration(NamedTuple):
    sec: int
    nanosec: int


class _Texture(NamedTuple):
    header: Header
    format: str
    data: bytes


class _MeshFile(NamedTuple):
    filename: str
    data: bytes


class MarkerView(NamedTuple):
    """A ``visualization_msgs/Marker`` as plain attributes, its unused fields empty."""

    header: Header
    ns: str
    id: int
    type: int
    action: int
    pose: PoseView
    scale: VectorView
    color: _Color
    text: str = ""
    lifetime: _Duration = _Duration(0, 0)
    frame_locked: bool = False
    points: tuple = ()
    colors: tuple = ()
    texture_resource: str = ""
    texture: _Texture = _Texture(Header(), "", b"")
    uv_coordinates: tuple = ()
    mesh_resource: str = ""
    mesh_file: _MeshFile = _MeshFile("", b"")
    mesh_use_embedded_materials: bool = False


class MarkerArrayView(NamedTuple):
    """A ``visualization_msgs/MarkerArray`` of ``MarkerView`` (and rclpy DELETE markers)."""

    markers: list

    MSGTYPE = "visualization_msgs/msg/MarkerArray"


def _landmark_views(header: Header, key: int, row: list[float], major: float, minor: float,
                    angle: float) -> list[MarkerView]:
    """The ellipse and the label of one landmark (``row``: x, y, cov xx xy yy, existence, id)."""
    x, y, existence, landmark_id = row[0], row[1], row[5], int(row[6])
    return [ellipse_view(header, key, (x, y, angle), major, minor,
                         (0.1, 0.4, 1.0, 0.25 + 0.6 * existence)),
            label_view(header, key, (x, y, LABEL_LIFT),
                       str(landmark_id) if landmark_id >= 0 else f"k{key}")]


def ellipse_view(header: Header, key: int, pose: Sequence[float], major: float, minor: float,
                 color: Sequence[float]) -> MarkerView:
    """A flat CYLINDER of the given full axis lengths (m), its major axis along ``pose``'s
    heading (namespace ``ELLIPSE_NAMESPACE``), colour (r, g, b, a)."""
    return MarkerView(header, ELLIPSE_NAMESPACE, key, Marker.CYLINDER, Marker.ADD,
                      planar_pose_view(pose), VectorView(major, minor, ELLIPSE_HEIGHT),
                      _Color(*color))


def label_view(header: Header, key: int, position: Sequence[float], text: str) -> MarkerView:
    """A white TEXT_VIEW_FACING label at (x, y, z) (namespace ``LABEL_NAMESPACE``)."""
    return MarkerView(header, LABEL_NAMESPACE, key, Marker.TEXT_VIEW_FACING, Marker.ADD,
                      PoseView(VectorView(*(float(value) for value in position[:3])),
                               QuaternionView(0.0, 0.0, 0.0, 1.0)),
                      VectorView(0.0, 0.0, LABEL_HEIGHT), _Color(1.0, 1.0, 1.0, 1.0), text)


def marker_from_view(view: MarkerView) -> Marker:
    """The rclpy ``Marker`` of a ``MarkerView`` (its pose, scale, colour and text; the other
    fields keep their defaults, as in the view). Filled in place: passing new sub-messages to
    the constructor would build the defaults as well."""
    marker = Marker()
    marker.header, marker.ns, marker.id = view.header, view.ns, view.id
    marker.type, marker.action, marker.text = view.type, view.action, view.text
    fill_pose(marker.pose, view.pose)
    scale, color = marker.scale, marker.color
    scale.x, scale.y, scale.z = view.scale
    color.r, color.g, color.b, color.a = view.color
    return marker


def ellipse_marker(header: Header, key: int, pose: Sequence[float], major: float,
                   minor: float, color: ColorRGBA) -> Marker:
    """``ellipse_view`` as an rclpy ``Marker``."""
    return marker_from_view(ellipse_view(header, key, pose, major, minor,
                                         (color.r, color.g, color.b, color.a)))


def label_marker(header: Header, key: int, position: Sequence[float], text: str) -> Marker:
    """``label_view`` as an rclpy ``Marker``."""
    return marker_from_view(label_view(header, key, position, text))


def delete_markers(header: Header, keys: Sequence[int], namespaces: Sequence[str]
                   ) -> list[Marker]:
    """DELETE markers for every key in every namespace (objects gone since the last array)."""
    return [Marker(header=header, ns=namespace, id=int(key), action=Marker.DELETE)
            for key in keys for namespace in namespaces]
