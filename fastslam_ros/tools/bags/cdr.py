# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Direct CDR reading and writing of the few message types a replay handles per message.

A replay reads about ten odometry messages per landmark cloud and writes a pose and a transform
per cloud; the generic (de)serializers and the message objects around them cost more than the
filter's prediction. These functions read and write the little-endian CDR bytes of those types
directly, byte for byte as rosbags' serializer writes them (padding zeroed).

The readers return plain look-alike objects holding the fields the nodes' input readers use
(``ros_io`` only reads message attributes), or None for anything they do not read exactly as
the generic deserializer would (big-endian encapsulation, a size that does not add up, a
string without its NUL, text that is not UTF-8): the caller then takes the generic path.
"""
from __future__ import annotations

import functools
import struct
from typing import Any, NamedTuple

import numpy as np

from fastslam_ros.core.geometry import yaw_to_quaternion

CDR_LE = b"\x00\x01\x00\x00"
"""Encapsulation header of little-endian plain CDR."""

_U32 = struct.Struct("<I")
_STAMP = struct.Struct("<iI")
_DOUBLES7 = struct.Struct("<7d")
_CLOUD_SIZE = struct.Struct("<II")
_FIELD_TAIL = struct.Struct("<IBxxxI")
_STEPS = struct.Struct("<II")
_ODOMETRY_TAIL = (7 + 36 + 6 + 36) * 8
"""Bytes of an Odometry after its child_frame_id's 8-alignment: pose, covariance, twist,
covariance."""


class Stamp(NamedTuple):
    """``builtin_interfaces/Time``."""

    sec: int
    nanosec: int


class Header(NamedTuple):
    """``std_msgs/Header``."""

    stamp: Stamp
    frame_id: str


class Point(NamedTuple):
    """``geometry_msgs/Point``."""

    x: float
    y: float
    z: float


class Quaternion(NamedTuple):
    """``geometry_msgs/Quaternion``."""

    x: float
    y: float
    z: float
    w: float


class Pose(NamedTuple):
    """``geometry_msgs/Pose``."""

    position: Point
    orientation: Quaternion


class PoseOnly(NamedTuple):
    """A ``PoseWithCovariance`` without its covariance (which the odometry reader ignores)."""

    pose: Pose


class OdometryView(NamedTuple):
    """A ``nav_msgs/Odometry`` without its twist and covariances."""

    header: Header
    child_frame_id: str
    pose: PoseOnly


class PointFieldView(NamedTuple):
    """``sensor_msgs/PointField``."""

    name: str
    offset: int
    datatype: int
    count: int


class PointCloudView(NamedTuple):
    """A ``sensor_msgs/PointCloud2``; ``data`` is a read-only view of the message bytes."""

    header: Header
    height: int
    width: int
    fields: list[PointFieldView]
    is_bigendian: bool
    point_step: int
    row_step: int
    data: memoryview
    is_dense: bool


def _string(raw: memoryview, at: int) -> tuple[str, int]:
    """The CDR string at absolute offset ``at`` (4-aligned first) and the offset after it;
    ValueError when it does not fit, has no NUL at its end or one inside (rclpy would cut the
    text there)."""
    at += -(at - 4) % 4
    (size,) = _U32.unpack_from(raw, at)
    end = at + 4 + size
    if size == 0 or end > len(raw) or raw[end - 1] != 0 or 0 in raw[at + 4:end - 1]:
        raise ValueError("bad CDR string")
    return str(raw[at + 4:end - 1], "utf-8"), end


def _header(raw: memoryview) -> tuple[Header, int]:
    sec, nanosec = _STAMP.unpack_from(raw, 4)
    frame_id, at = _string(raw, 12)
    return Header(Stamp(sec, nanosec), frame_id), at


_odometry_frames: tuple[bytes | None, str, str, int] = (None, "", "", 0)
"""The bytes of the last odometry's frame strings (from offset 12 to its pose), the two frames
they read as and the pose's offset: a stream repeats its frames, and a message whose bytes there
are the same reads the same without parsing them again."""
_new = tuple.__new__
"""A NamedTuple from a tuple, without the Python call of its ``__new__`` (six per odometry)."""


def read_odometry(raw: bytes | memoryview) -> OdometryView | None:
    """The header, child frame and pose of a serialized ``nav_msgs/Odometry`` (see above)."""
    global _odometry_frames
    raw = memoryview(raw)
    if raw[:4] != CDR_LE:
        return None
    try:
        stamp = _STAMP.unpack_from(raw, 4)
        seen, frame_id, child_frame_id, at = _odometry_frames
        if raw[12:at] != seen:
            frame_id, at = _string(raw, 12)
            child_frame_id, at = _string(raw, at)
            at += -(at - 4) % 8
            _odometry_frames = (bytes(raw[12:at]), frame_id, child_frame_id, at)
        if len(raw) != at + _ODOMETRY_TAIL:
            return None
        x, y, z, qx, qy, qz, qw = _DOUBLES7.unpack_from(raw, at)
    except (ValueError, struct.error, IndexError):
        return None
    pose = _new(Pose, (_new(Point, (x, y, z)), _new(Quaternion, (qx, qy, qz, qw))))
    return _new(OdometryView, (_new(Header, (_new(Stamp, stamp), frame_id)), child_frame_id,
                               _new(PoseOnly, (pose,))))


def read_point_cloud(raw: bytes | memoryview) -> PointCloudView | None:
    """Every field of a serialized ``sensor_msgs/PointCloud2`` (see above)."""
    raw = memoryview(raw)
    if raw[:4] != CDR_LE:
        return None
    try:
        header, at = _header(raw)
        at += -(at - 4) % 4
        height, width = _CLOUD_SIZE.unpack_from(raw, at)
        (count,) = _U32.unpack_from(raw, at + 8)
        at += 12
        if count > len(raw):
            return None
        fields = []
        for _ in range(count):
            name, at = _string(raw, at)
            at += -(at - 4) % 4
            offset, datatype, field_count = _FIELD_TAIL.unpack_from(raw, at)
            fields.append(PointFieldView(name, offset, datatype, field_count))
            at += _FIELD_TAIL.size
        is_bigendian = raw[at]
        at += 1
        at += -(at - 4) % 4
        point_step, row_step = _STEPS.unpack_from(raw, at)
        (size,) = _U32.unpack_from(raw, at + 8)
        start = at + 12
        end = start + size
        if end + 1 > len(raw) or len(raw) - (end + 1) >= 4 or is_bigendian > 1 or raw[end] > 1:
            return None
    except (ValueError, struct.error, IndexError):
        return None
    return PointCloudView(header, height, width, fields, bool(is_bigendian), point_step,
                          row_step, raw[start:end], bool(raw[end]))


def _cdr_string(buffer: bytearray, text: str) -> None:
    """Append a CDR string (uint32 length with the NUL, the bytes, the NUL), 4-aligned."""
    buffer += bytes(-len(buffer) % 4)
    buffer += _string_piece(text)


_frame_bytes: dict[tuple[int, tuple[str, ...]], bytes] = {}


def _frames(start: int, frames: tuple[str, ...]) -> bytes:
    """The CDR strings ``frames`` written at offset ``start`` of the payload, then the padding
    to the next 8-aligned offset (the doubles that follow); cached."""
    key = (start, frames)
    cached = _frame_bytes.get(key)
    if cached is None:
        buffer = bytearray(start)
        for frame in frames:
            _cdr_string(buffer, frame)
        buffer += bytes(-len(buffer) % 8)
        cached = _frame_bytes[key] = bytes(buffer[start:])
    return cached


_TF_HEAD = struct.Struct("<4sIii")
_STAMPED_HEAD = struct.Struct("<4siI")


def tf_message_cdr(sec: int, nanosec: int, parent: str, child: str, translation,
                   rotation) -> bytes:
    """The serialized ``tf2_msgs/TFMessage`` holding one transform parent -> child at stamp
    (sec, nanosec), translation (x, y, z), rotation quaternion (x, y, z, w), all written as
    given: byte for byte what rosbags' serializer writes, written directly (a replay records
    one per odometry message, where a message object and the generic serializer cost more
    than the filter's prediction)."""
    # After the 12 bytes of count and stamp: both strings, then padding to the doubles.
    return b"".join((_TF_HEAD.pack(CDR_LE, 1, sec, nanosec), _frames(12, (parent, child)),
                     _DOUBLES7.pack(*translation, *rotation)))


_TF_COUNT = struct.Struct("<4sI")


def odometry_tf_cdr(raw: bytes | memoryview, odom_frame: str, base_frame: str) -> bytes | None:
    """``tf_message_cdr`` of the odometry ``read_odometry`` read last from ``raw``: its stamp
    and its pose's bytes copied, its frames (the given ones where empty), the bytes the function
    writes from the message read; None for bytes it did not read (the caller then writes the
    transform from the message)."""
    seen, frame_id, child_frame_id, at = _odometry_frames
    raw = memoryview(raw)
    if raw[12:at] != seen or len(raw) != at + _ODOMETRY_TAIL or raw[:4] != CDR_LE:
        return None
    return b"".join((_TF_COUNT.pack(CDR_LE, 1), raw[4:12],
                     _frames(12, (frame_id or odom_frame, child_frame_id or base_frame)),
                     raw[at:at + _DOUBLES7.size]))


def transform_stamped_cdr(msg: Any) -> bytes:
    """A serialized ``geometry_msgs/TransformStamped`` (an rclpy or look-alike message)."""
    stamp, t, r = msg.header.stamp, msg.transform.translation, msg.transform.rotation
    return b"".join((_STAMPED_HEAD.pack(CDR_LE, stamp.sec, stamp.nanosec),
                     _frames(8, (msg.header.frame_id, msg.child_frame_id)),
                     _DOUBLES7.pack(t.x, t.y, t.z, r.x, r.y, r.z, r.w)))


def pose_with_covariance_stamped_cdr(msg: Any) -> bytes:
    """A serialized ``geometry_msgs/PoseWithCovarianceStamped`` (rclpy or look-alike)."""
    stamp, pose = msg.header.stamp, msg.pose.pose
    p, q = pose.position, pose.orientation
    return b"".join((_STAMPED_HEAD.pack(CDR_LE, stamp.sec, stamp.nanosec),
                     _frames(8, (msg.header.frame_id,)),
                     _DOUBLES7.pack(p.x, p.y, p.z, q.x, q.y, q.z, q.w),
                     np.asarray(msg.pose.covariance, dtype="<f8").tobytes()))


@functools.lru_cache(maxsize=4096)
def _string_piece(text: str) -> bytes:
    """A CDR string from a 4-aligned offset: uint32 length with the NUL, the bytes, the NUL
    (outputs repeat the same frames, namespaces, keys and values; cached)."""
    encoded = text.encode() + b"\0"
    return _U32.pack(len(encoded)) + encoded


class _Buffer:
    """CDR bytes being written; alignment counts from ``origin`` (the payload's start)."""

    def __init__(self, start: bytes, origin: int) -> None:
        self.data = bytearray(start)
        self.origin = origin

    def align(self, size: int) -> None:
        self.data += bytes(-(len(self.data) - self.origin) % size)

    def u32(self, value: int) -> None:
        self.align(4)
        self.data += _U32.pack(value)

    def string(self, text: str) -> None:
        self.align(4)
        self.data += _string_piece(text)

    def header(self, header: Any) -> None:
        self.align(4)
        self.data += _STAMP.pack(header.stamp.sec, header.stamp.nanosec)
        self.string(header.frame_id)

    def pose(self, pose: Any) -> None:
        p, q = pose.position, pose.orientation
        self.align(8)
        self.data += _DOUBLES7.pack(p.x, p.y, p.z, q.x, q.y, q.z, q.w)


def pose_array_cdr(msg: Any) -> bytes:
    """A serialized ``geometry_msgs/PoseArray`` (rclpy or look-alike)."""
    buffer = _Buffer(CDR_LE, 4)
    buffer.header(msg.header)
    buffer.u32(len(msg.poses))
    for pose in msg.poses:
        buffer.pose(pose)
    return bytes(buffer.data)


def planar_pose_array_cdr(msg: Any) -> bytes:
    """A serialized ``geometry_msgs/PoseArray`` from a ``ros_io.PlanarPoseArray``: the bytes of
    ``pose_array_cdr(ros_io.pose_array(header, planar))`` without a Pose per pose."""
    buffer = _Buffer(CDR_LE, 4)
    buffer.header(msg.header)
    planar = np.asarray(msg.planar, dtype=float).tolist()
    buffer.u32(len(planar))
    if planar:
        buffer.align(8)
        values = [value for x, y, yaw in planar
                  for value in (x, y, 0.0, *yaw_to_quaternion(yaw))]
        buffer.data += struct.pack(f"<{len(values)}d", *values)
    return bytes(buffer.data)


def point_cloud2_cdr(msg: Any) -> bytes:
    """A serialized ``sensor_msgs/PointCloud2`` (rclpy or look-alike)."""
    buffer = _Buffer(CDR_LE, 4)
    buffer.header(msg.header)
    buffer.u32(msg.height)
    buffer.u32(msg.width)
    buffer.u32(len(msg.fields))
    for point_field in msg.fields:
        buffer.string(point_field.name)
        buffer.align(4)
        buffer.data += _FIELD_TAIL.pack(point_field.offset, point_field.datatype,
                                        point_field.count)
    buffer.data.append(1 if msg.is_bigendian else 0)
    buffer.u32(msg.point_step)
    buffer.u32(msg.row_step)
    _bytes_sequence(buffer, msg.data)
    buffer.data.append(1 if msg.is_dense else 0)
    return bytes(buffer.data)


def diagnostic_array_cdr(msg: Any) -> bytes:
    """A serialized ``diagnostic_msgs/DiagnosticArray`` (rclpy, whose ``level`` is one byte, or
    look-alike)."""
    buffer = _Buffer(CDR_LE, 4)
    buffer.header(msg.header)
    buffer.u32(len(msg.status))
    for status in msg.status:
        level = status.level
        buffer.data += level if isinstance(level, bytes) else bytes((level,))
        buffer.string(status.name)
        buffer.string(status.message)
        buffer.string(status.hardware_id)
        buffer.u32(len(status.values))
        for value in status.values:
            buffer.string(value.key)
            buffer.string(value.value)
    return bytes(buffer.data)


def pose_stamped_piece(msg: Any, alignment: int) -> bytes:
    """The bytes of a ``geometry_msgs/PoseStamped`` inside a message, starting at a payload
    offset that is ``alignment`` (0 or 4) modulo 8."""
    buffer = _Buffer(bytes(alignment), 0)
    buffer.header(msg.header)
    buffer.pose(msg.pose)
    return bytes(buffer.data[alignment:])


class SequenceCdr:
    """Serializes messages made of an optional header and one sequence of sub-messages, most of
    them those of the previous message (``ros_markers.MarkerBuilder`` and ``ros_io.PathBuilder``
    reuse the sub-messages of what did not change).

    Each element starts 4-aligned and its bytes depend only on whether it starts 8-aligned
    (its float64 fields' padding): each is serialized once per alignment it is met at and the
    message joined from the pieces (a map of a few hundred landmarks costs a fraction of a
    millisecond instead of ten). ``piece(element, alignment)`` serializes one element."""

    def __init__(self, field: str, piece: Any, has_header: bool) -> None:
        self._field, self._piece, self._has_header = field, piece, has_header
        self._pieces: dict[int, tuple[Any, dict[int, bytes]]] = {}

    def serialize(self, msg: Any) -> bytes:
        elements = getattr(msg, self._field)
        buffer = _Buffer(CDR_LE, 4)
        if self._has_header:
            buffer.header(msg.header)
        buffer.u32(len(elements))
        parts = [bytes(buffer.data)]
        offset, pieces, kept = len(buffer.data) - 4, self._pieces, {}
        for element in elements:
            padding = -offset % 4
            if padding:
                parts.append(bytes(padding))
                offset += padding
            entry = kept.get(id(element)) or pieces.get(id(element)) or (element, {})
            kept[id(element)] = entry  # the element is held, so its id is not reused meanwhile
            piece = entry[1].get(offset % 8)
            if piece is None:
                piece = entry[1][offset % 8] = self._piece(element, offset % 8)
            parts.append(piece)
            offset += len(piece)
        self._pieces = kept
        return b"".join(parts)


def _bytes_sequence(buffer: _Buffer, data: Any) -> None:
    buffer.u32(len(data))
    buffer.data += memoryview(data).cast("B") if len(data) else b""


_FLOATS4 = struct.Struct("<4f")
_MARKER_IDS = struct.Struct("<iii")
_MARKER_TAIL = struct.Struct("<10d4fiI?")
"""A Marker's pose (7 doubles), scale (3), color (4 float32), lifetime and frame_locked."""


def marker_piece(marker: Any, alignment: int) -> bytes:
    """The bytes of a ``visualization_msgs/Marker`` (rclpy or look-alike) inside a message,
    starting at a payload offset that is ``alignment`` (0 or 4) modulo 8."""
    buffer = _Buffer(bytes(alignment), 0)
    buffer.header(marker.header)
    buffer.string(marker.ns)
    buffer.align(4)
    buffer.data += _MARKER_IDS.pack(marker.id, marker.type, marker.action)
    buffer.align(8)
    pose, scale, color, lifetime = marker.pose, marker.scale, marker.color, marker.lifetime
    p, q = pose.position, pose.orientation
    buffer.data += _MARKER_TAIL.pack(p.x, p.y, p.z, q.x, q.y, q.z, q.w, scale.x, scale.y,
                                     scale.z, color.r, color.g, color.b, color.a, lifetime.sec,
                                     lifetime.nanosec, marker.frame_locked)
    buffer.u32(len(marker.points))
    for point in marker.points:
        buffer.align(8)
        buffer.data += struct.pack("<3d", point.x, point.y, point.z)
    buffer.u32(len(marker.colors))
    for rgba in marker.colors:
        buffer.data += _FLOATS4.pack(rgba.r, rgba.g, rgba.b, rgba.a)
    buffer.string(marker.texture_resource)
    buffer.header(marker.texture.header)
    buffer.string(marker.texture.format)
    _bytes_sequence(buffer, marker.texture.data)
    buffer.u32(len(marker.uv_coordinates))
    for uv in marker.uv_coordinates:
        buffer.data += struct.pack("<2f", uv.u, uv.v)
    buffer.string(marker.text)
    buffer.string(marker.mesh_resource)
    buffer.string(marker.mesh_file.filename)
    _bytes_sequence(buffer, marker.mesh_file.data)
    buffer.data.append(1 if marker.mesh_use_embedded_materials else 0)
    return bytes(buffer.data[alignment:])
