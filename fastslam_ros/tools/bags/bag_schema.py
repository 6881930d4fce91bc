# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Bag schema v1: the topics every fastslam_ros tool reads and writes, and a numpy view of them.

| topic | type | frame | content |
|---|---|---|---|
| ``/odom`` | ``nav_msgs/Odometry`` | ``odom`` -> ``base_link`` | wheel odometry pose |
| ``/landmarks`` | ``sensor_msgs/PointCloud2`` | sensor | x y z (float32), id (int32, -1 unknown) |
| ``/ground_truth/pose`` | ``nav_msgs/Odometry`` | ``map`` | true base pose |
| ``/ground_truth/landmarks`` | ``sensor_msgs/PointCloud2`` | ``map`` | x y z id, one message |

A position-only reference (GPS) has an identity orientation and a yaw variance
(``pose.covariance[35]``) of -1. When the reference measures another point of the robot than the
base (a GPS antenna), its ``child_frame_id`` names that point and ``/tf_static``
(``tf2_msgs/TFMessage``) holds the static transform base frame -> that point; the evaluation
then compares the estimated position of that point. Bags are MCAP by default, sqlite3 on
request; both are read.
Stamps are float seconds in Python and ``builtin_interfaces/Time`` in the bag; every message is
logged at its header stamp.
"""
from __future__ import annotations

import importlib
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

import numpy as np
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.interfaces import Connection
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from fastslam_ros.core.geometry import quaternion_to_yaw, yaw_to_quaternion
from fastslam_ros.node_support.timing import seconds_to_nanoseconds
from fastslam_ros.output import staged_output

ODOM_TOPIC = "/odom"
LANDMARKS_TOPIC = "/landmarks"
SCAN_TOPIC = "/scan"
MAP_TOPIC = "/map"
GROUND_TRUTH_POSE_TOPIC = "/ground_truth/pose"
GROUND_TRUTH_LANDMARKS_TOPIC = "/ground_truth/landmarks"
PEOPLE_TRUTH_TOPIC = "/ground_truth/people"
TF_STATIC_TOPIC = "/tf_static"
REPLAY_INFO_TOPIC = "/fastslam_replay/info"
"""One message of the replay: its parameters, seed and counters, for the evaluation."""
INITIAL_POSE_TOPIC = "/initialpose"
"""Fed to a node too when a bag has it (RViz "2D Pose Estimate" clicks, recorded)."""
ODOMETRY_TYPE = "nav_msgs/msg/Odometry"
CLOUD_TYPE = "sensor_msgs/msg/PointCloud2"
TF_TYPE = "tf2_msgs/msg/TFMessage"
TOPIC_TYPES = {
    ODOM_TOPIC: ODOMETRY_TYPE, LANDMARKS_TOPIC: CLOUD_TYPE, GROUND_TRUTH_POSE_TOPIC: ODOMETRY_TYPE,
    GROUND_TRUTH_LANDMARKS_TOPIC: CLOUD_TYPE, TF_STATIC_TOPIC: TF_TYPE, "/tf": TF_TYPE,
    REPLAY_INFO_TOPIC: "std_msgs/msg/String", "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
    INITIAL_POSE_TOPIC: "geometry_msgs/msg/PoseWithCovarianceStamped",
    MAP_TOPIC: "nav_msgs/msg/OccupancyGrid", SCAN_TOPIC: "sensor_msgs/msg/LaserScan",
    "/fastslam/pose": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "/fastslam/path": "nav_msgs/msg/Path", "/fastslam/map_cloud": CLOUD_TYPE}
"""The message type of each topic the tools read (schema v1, people bags, a replay's outputs):
a bag that holds one of them with another type is refused before any message is read."""
STORAGE_PLUGINS = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}
POSITION_ONLY_YAW_VARIANCE = -1.0
"""``pose.covariance[35]`` of a position-only reference: its orientation carries no information."""

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)

# sensor_msgs/PointField datatype codes -> numpy dtypes.
POINT_FIELD_DTYPES = {1: np.int8, 2: np.uint8, 3: np.int16, 4: np.uint16, 5: np.int32,
                      6: np.uint32, 7: np.float32, 8: np.float64}
POINT_FIELD_FLOAT32 = 7
POINT_FIELD_INT32 = 5
LANDMARK_CLOUD_DTYPE = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<i4")])


class SchemaError(ValueError):
    """A bag that does not follow schema v1 (missing topics, wrong fields)."""


KNOWN_MESSAGE_TYPES = (
    "nav_msgs/msg/Odometry", "nav_msgs/msg/Path", "sensor_msgs/msg/PointCloud2",
    "geometry_msgs/msg/PoseArray", "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped", "geometry_msgs/msg/TransformStamped",
    "visualization_msgs/msg/MarkerArray", "diagnostic_msgs/msg/DiagnosticArray",
    "std_msgs/msg/String", "rosgraph_msgs/msg/Clock", "tf2_msgs/msg/TFMessage",
    "nav_msgs/msg/OccupancyGrid", "sensor_msgs/msg/LaserScan")
"""Every message type the tools read, write or play (bag schema v1, the people bags and the
nodes' outputs)."""


def _message_class(msgtype: str) -> type | None:
    """The rclpy class of one of KNOWN_MESSAGE_TYPES (None when its package is not
    installed); the module name comes from the table, never from a bag."""
    package, _, name = msgtype.split("/")
    try:
        return getattr(importlib.import_module(f"{package}.msg"), name)
    except ImportError:
        return None


def ros_message_class(msgtype: str, topic: str = "") -> type:
    """The rclpy message class of a known ``pkg/msg/Name``; ``SchemaError`` for any other.

    Types are looked up in a fixed table, never imported by the name a bag declares (a bag
    could otherwise make a tool import any module)."""
    where = f"topic {topic}: " if topic else ""
    if msgtype not in KNOWN_MESSAGE_TYPES:
        raise SchemaError(f"{where}message type {msgtype!r} is not one the tools handle "
                          f"({', '.join(KNOWN_MESSAGE_TYPES)})")
    cls = _message_class(msgtype)
    if cls is None:
        raise SchemaError(f"{where}message type {msgtype!r}: its ROS package is not installed")
    return cls


@dataclass
class PoseSeries:
    """Timed planar poses: ``stamps`` (N,) s, ``poses`` (N, 3) x, y (m), theta (rad)."""

    stamps: np.ndarray
    poses: np.ndarray
    frame_id: str = "odom"
    child_frame_id: str = "base_link"
    position_only: bool = False
    reference_offset: np.ndarray | None = None
    """Ground truth only: (x, y) of the measured point (``child_frame_id``) in the robot's base
    frame when it is not the base itself, e.g. a GPS antenna; None: the base."""


@dataclass
class LandmarkScans:
    """One entry per sensor reading: points (K, 2) in the sensor frame and ids (K,) int32."""

    stamps: np.ndarray
    points: list[np.ndarray]
    ids: list[np.ndarray]
    frame_id: str = "sensor"


@dataclass
class LandmarkSet:
    """Landmark positions (L, 2) in the map frame and their ids (L,) int32."""

    positions: np.ndarray
    ids: np.ndarray


@dataclass
class SchemaBag:
    """Everything a schema-v1 bag holds, as arrays."""

    odometry: PoseSeries
    scans: LandmarkScans
    ground_truth: PoseSeries | None = None
    landmarks_truth: LandmarkSet | None = None


@dataclass
class _Record:
    """One serialized message waiting to be written."""

    stamp_ns: int
    order: int
    topic: str
    data: bytes = field(repr=False)


# ---------------------------------------------------------------- conversions


def stamp_to_ns(stamp: float) -> int:
    """Float seconds -> integer nanoseconds (``node_support.timing.seconds_to_nanoseconds``)."""
    return seconds_to_nanoseconds(stamp)


def ns_to_stamp(stamp_ns: int) -> float:
    """Integer nanoseconds -> float seconds."""
    seconds, nanoseconds = divmod(int(stamp_ns), 1_000_000_000)
    return seconds + nanoseconds / 1e9


def time_msg_to_stamp(time_msg: Any) -> float:
    """``builtin_interfaces/Time`` (rosbags or rclpy) -> float seconds."""
    return time_msg.sec + time_msg.nanosec / 1e9


def _time_msg(stamp_ns: int) -> Any:
    seconds, nanoseconds = divmod(stamp_ns, 1_000_000_000)
    return TYPESTORE.types["builtin_interfaces/msg/Time"](sec=seconds, nanosec=nanoseconds)


def odometry_to_pose(msg: Any) -> tuple[float, float, float]:
    """(x, y, theta) of a ``nav_msgs/Odometry`` (rosbags or rclpy message)."""
    position = msg.pose.pose.position
    q = msg.pose.pose.orientation
    return position.x, position.y, quaternion_to_yaw(q.x, q.y, q.z, q.w)


def cloud_to_arrays(msg: Any) -> dict[str, np.ndarray]:
    """Every field of a ``sensor_msgs/PointCloud2`` (rosbags or rclpy) as a 1-D array by name."""
    endian = ">" if msg.is_bigendian else "<"
    names, formats, offsets = [], [], []
    for point_field in msg.fields:
        if point_field.datatype not in POINT_FIELD_DTYPES or point_field.count != 1:
            continue
        names.append(point_field.name)
        formats.append(np.dtype(POINT_FIELD_DTYPES[point_field.datatype]).newbyteorder(endian))
        offsets.append(point_field.offset)
    dtype = np.dtype({"names": names, "formats": formats, "offsets": offsets,
                      "itemsize": msg.point_step})
    count = msg.width * msg.height
    raw = np.frombuffer(memoryview(msg.data).cast("B"), dtype=np.uint8)
    if count == 0:
        return {name: np.zeros(0, dtype=dtype.fields[name][0]) for name in names}
    if msg.row_step == msg.width * msg.point_step:
        points = raw[:count * msg.point_step].view(dtype)
    else:
        rows = raw.reshape(msg.height, msg.row_step)[:, :msg.width * msg.point_step]
        points = np.ascontiguousarray(rows).view(dtype).reshape(-1)
    return {name: points[name].astype(points.dtype[name].newbyteorder("="))
            for name in names}


def landmark_cloud_arrays(msg: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(points (K, 2) float32, ids (K,) int32)`` of a landmark cloud; ids -1 when absent."""
    fields = cloud_to_arrays(msg)
    if "x" not in fields or "y" not in fields:
        raise SchemaError("landmark cloud without x/y fields")
    points = np.stack([fields["x"], fields["y"]], axis=1).astype(np.float32)
    if "id" in fields:
        ids = fields["id"].astype(np.int32)
    else:
        ids = np.full(len(points), -1, dtype=np.int32)
    return points, ids


# ---------------------------------------------------------------- message builders


def _odometry_message(stamp_ns: int, pose: np.ndarray, frame_id: str, child_frame_id: str,
                      position_only: bool) -> Any:
    types = TYPESTORE.types
    vector3 = types["geometry_msgs/msg/Vector3"]
    covariance = np.zeros(36)
    if position_only:
        qx, qy, qz, qw = 0.0, 0.0, 0.0, 1.0
        covariance[35] = POSITION_ONLY_YAW_VARIANCE
    else:
        qx, qy, qz, qw = yaw_to_quaternion(pose[2])
    return types[ODOMETRY_TYPE](
        header=types["std_msgs/msg/Header"](stamp=_time_msg(stamp_ns), frame_id=frame_id),
        child_frame_id=child_frame_id,
        pose=types["geometry_msgs/msg/PoseWithCovariance"](
            pose=types["geometry_msgs/msg/Pose"](
                position=types["geometry_msgs/msg/Point"](x=float(pose[0]), y=float(pose[1]),
                                                          z=0.0),
                orientation=types["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw)),
            covariance=covariance),
        twist=types["geometry_msgs/msg/TwistWithCovariance"](
            twist=types["geometry_msgs/msg/Twist"](linear=vector3(x=0.0, y=0.0, z=0.0),
                                                   angular=vector3(x=0.0, y=0.0, z=0.0)),
            covariance=np.zeros(36)))


def _landmark_cloud_message(stamp_ns: int, points: np.ndarray, ids: np.ndarray,
                            frame_id: str) -> Any:
    types = TYPESTORE.types
    point_field = types["sensor_msgs/msg/PointField"]
    records = np.zeros(len(points), dtype=LANDMARK_CLOUD_DTYPE)
    if len(points):
        records["x"] = points[:, 0]
        records["y"] = points[:, 1]
        records["id"] = ids
    fields = [point_field(name=name, offset=offset, datatype=datatype, count=1)
              for name, offset, datatype in (("x", 0, POINT_FIELD_FLOAT32),
                                             ("y", 4, POINT_FIELD_FLOAT32),
                                             ("z", 8, POINT_FIELD_FLOAT32),
                                             ("id", 12, POINT_FIELD_INT32))]
    return types[CLOUD_TYPE](
        header=types["std_msgs/msg/Header"](stamp=_time_msg(stamp_ns), frame_id=frame_id),
        height=1, width=len(points), fields=fields, is_bigendian=False,
        point_step=LANDMARK_CLOUD_DTYPE.itemsize,
        row_step=LANDMARK_CLOUD_DTYPE.itemsize * len(points),
        data=records.view(np.uint8), is_dense=True)


def transform_message(stamp_ns: int, parent: str, child: str, pose) -> Any:
    """rosbags ``geometry_msgs/TransformStamped`` parent -> child of a planar pose (x, y, yaw)."""
    types = TYPESTORE.types
    qx, qy, qz, qw = yaw_to_quaternion(float(pose[2]))
    return types["geometry_msgs/msg/TransformStamped"](
        header=types["std_msgs/msg/Header"](stamp=_time_msg(stamp_ns), frame_id=parent),
        child_frame_id=child,
        transform=types["geometry_msgs/msg/Transform"](
            translation=types["geometry_msgs/msg/Vector3"](x=float(pose[0]), y=float(pose[1]),
                                                           z=0.0),
            rotation=types["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw)))


def tf_message_bytes(transforms: list[Any]) -> bytes:
    """A serialized ``tf2_msgs/TFMessage`` of rosbags ``TransformStamped`` messages."""
    return _serialize(TYPESTORE.types[TF_TYPE](transforms=transforms), TF_TYPE)


def _static_transform_message(stamp_ns: int, parent: str, child: str, offset) -> Any:
    """``/tf_static`` with the one transform parent -> child, a planar translation."""
    transform = transform_message(stamp_ns, parent, child, (offset[0], offset[1], 0.0))
    return TYPESTORE.types[TF_TYPE](transforms=[transform])


def _serialize(msg: Any, msgtype: str) -> bytes:
    return bytes(TYPESTORE.serialize_cdr(msg, msgtype))


# ---------------------------------------------------------------- writing


@contextmanager
def open_writer(path: str | Path, storage: str = "mcap", overwrite: bool = False,
                inputs: Iterable[str | Path] = (),
                wrap: Callable[[Writer], Writer] | None = None) -> Iterator[Writer]:
    """An open rosbags ``Writer`` for a rosbag2 folder at ``path`` (``wrap`` adapts it before it
    opens), through ``output.staged_output``: the bag appears at ``path`` only when the block
    ends without an error; ``overwrite`` replaces an old bag there, never another folder nor
    one of ``inputs``."""
    if storage not in STORAGE_PLUGINS:
        raise ValueError(f"storage: must be one of {sorted(STORAGE_PLUGINS)} (got {storage!r})")
    with staged_output(path, overwrite, "bag", inputs) as staged:
        writer = Writer(staged, version=9, storage_plugin=STORAGE_PLUGINS[storage])
        with wrap(writer) if wrap is not None else writer as opened:
            yield opened


def write_schema_bag(path: str | Path, bag: SchemaBag, storage: str = "mcap",
                     overwrite: bool = False,
                     extra: Iterable[tuple[str, str, int, bytes]] = (),
                     inputs: Iterable[str | Path] = ()) -> Path:
    """Write ``bag`` as a schema-v1 rosbag2 folder at ``path`` (``mcap`` or ``sqlite3``);
    ``extra`` adds serialized messages (topic, msgtype, stamp ns, CDR bytes) of other topics;
    ``inputs`` are never replaced (``fastslam_ros.output``)."""
    extra = list(extra)
    records = list(_schema_records(bag))
    records += [_Record(stamp_ns, 4, topic, data) for topic, _, stamp_ns, data in extra]
    records.sort(key=lambda record: (record.stamp_ns, record.order))
    with open_writer(path, storage, overwrite, inputs) as writer:
        connections = {}
        for topic, msgtype in dict((topic, msgtype) for topic, msgtype, _, _ in extra).items():
            connections[topic] = writer.add_connection(topic, msgtype, typestore=TYPESTORE)
        for topic, msgtype in ((ODOM_TOPIC, ODOMETRY_TYPE), (LANDMARKS_TOPIC, CLOUD_TYPE),
                               (GROUND_TRUTH_POSE_TOPIC, ODOMETRY_TYPE),
                               (GROUND_TRUTH_LANDMARKS_TOPIC, CLOUD_TYPE),
                               (TF_STATIC_TOPIC, TF_TYPE)):
            if any(record.topic == topic for record in records):
                connections[topic] = writer.add_connection(topic, msgtype, typestore=TYPESTORE)
        for record in records:
            writer.write(connections[record.topic], record.stamp_ns, record.data)
    return Path(path)


def _schema_records(bag: SchemaBag) -> Iterable[_Record]:
    """Serialized messages of ``bag``; ``order`` breaks ties (truth, odometry, then scans)."""
    if bag.landmarks_truth is not None:
        first_stamp = min(_first_stamps(bag))
        truth = bag.landmarks_truth
        msg = _landmark_cloud_message(stamp_to_ns(first_stamp), np.asarray(truth.positions),
                                      np.asarray(truth.ids, dtype=np.int32), "map")
        yield _Record(stamp_to_ns(first_stamp), 0, GROUND_TRUTH_LANDMARKS_TOPIC,
                      _serialize(msg, CLOUD_TYPE))
    truth = bag.ground_truth
    if truth is not None and truth.reference_offset is not None:
        stamp_ns = stamp_to_ns(min(_first_stamps(bag)))
        msg = _static_transform_message(stamp_ns, bag.odometry.child_frame_id,
                                        truth.child_frame_id, truth.reference_offset)
        yield _Record(stamp_ns, 0, TF_STATIC_TOPIC, _serialize(msg, TF_TYPE))
    for order, topic, series in ((1, ODOM_TOPIC, bag.odometry),
                                 (2, GROUND_TRUTH_POSE_TOPIC, bag.ground_truth)):
        if series is None:
            continue
        for stamp, pose in zip(series.stamps, np.asarray(series.poses, dtype=float)):
            stamp_ns = stamp_to_ns(stamp)
            msg = _odometry_message(stamp_ns, pose, series.frame_id, series.child_frame_id,
                                    series.position_only)
            yield _Record(stamp_ns, order, topic, _serialize(msg, ODOMETRY_TYPE))
    scans = bag.scans
    for stamp, points, ids in zip(scans.stamps, scans.points, scans.ids):
        stamp_ns = stamp_to_ns(stamp)
        msg = _landmark_cloud_message(stamp_ns, np.asarray(points).reshape(-1, 2),
                                      np.asarray(ids, dtype=np.int32), scans.frame_id)
        yield _Record(stamp_ns, 3, LANDMARKS_TOPIC, _serialize(msg, CLOUD_TYPE))


def _first_stamps(bag: SchemaBag) -> list[float]:
    stamps = [series.stamps[0] for series in (bag.odometry, bag.ground_truth, bag.scans)
              if series is not None and len(series.stamps)]
    return stamps or [0.0]


# ---------------------------------------------------------------- reading


def bag_topics(path: str | Path) -> dict[str, str]:
    """``{topic: msgtype}`` of a rosbag2 folder (mcap or sqlite3)."""
    with AnyReader([Path(path)], default_typestore=TYPESTORE) as reader:
        return {connection.topic: connection.msgtype for connection in reader.connections}


def check_topic_types(topics: dict[str, str], where: str | Path,
                      wanted: Iterable[str] | None = None) -> None:
    """SchemaError when a topic of ``topics`` ({topic: msgtype}; only those in ``wanted`` when
    given) has another type than ``TOPIC_TYPES`` says."""
    names = topics if wanted is None else [topic for topic in wanted if topic in topics]
    wrong = [f"{topic} is {topics[topic]}, expected {TOPIC_TYPES[topic]}" for topic in names
             if topic in TOPIC_TYPES and topics[topic] != TOPIC_TYPES[topic]]
    if wrong:
        raise SchemaError(f"{where}: topic{'s' if len(wrong) > 1 else ''} of the wrong type: "
                          f"{'; '.join(wrong)}")


def read_topic(path: str | Path, topic: str) -> tuple[np.ndarray, list[Any]]:
    """``(log stamps (N,) s, deserialized rosbags messages)`` of one topic, in time order.

    Works on any rosbag2 folder, including the node outputs a replay records. An absent topic
    gives empty results.
    """
    return read_topics(path, [topic])[topic]


def read_topics(path: str | Path, topics: Iterable[str]) -> dict[str, tuple[np.ndarray, list[Any]]]:
    """``read_topic`` for several topics in one pass over the bag."""
    wanted = list(topics)
    stamps: dict[str, list[float]] = {topic: [] for topic in wanted}
    messages: dict[str, list[Any]] = {topic: [] for topic in wanted}
    with AnyReader([Path(path)], default_typestore=TYPESTORE) as reader:
        check_topic_types({c.topic: c.msgtype for c in reader.connections}, path, wanted)
        connections = [c for c in reader.connections if c.topic in stamps]
        # An empty selection would mean "every connection" to rosbags.
        for connection, stamp_ns, raw in (reader.messages(connections=connections)
                                          if connections else ()):
            stamps[connection.topic].append(ns_to_stamp(stamp_ns))
            messages[connection.topic].append(_decoded(reader, connection, raw, path))
    return {topic: (np.asarray(stamps[topic], dtype=float), messages[topic]) for topic in wanted}


def read_last(path: str | Path, topics: Iterable[str]) -> dict[str, tuple[float, Any]]:
    """``{topic: (log stamp s, message)}`` of the last message of each present topic.

    Only the kept messages are deserialized, so a long ``nav_msgs/Path`` history costs nothing.
    """
    wanted = set(topics)
    last: dict[str, tuple[int, Connection, bytes]] = {}
    with AnyReader([Path(path)], default_typestore=TYPESTORE) as reader:
        check_topic_types({c.topic: c.msgtype for c in reader.connections}, path, wanted)
        connections = [c for c in reader.connections if c.topic in wanted]
        for connection, stamp_ns, raw in (reader.messages(connections=connections)
                                          if connections else ()):
            last[connection.topic] = (stamp_ns, connection, raw)
        return {topic: (ns_to_stamp(stamp_ns), _decoded(reader, connection, raw, path))
                for topic, (stamp_ns, connection, raw) in last.items()}


def _decoded(reader: AnyReader, connection: Connection, raw: bytes, path: str | Path) -> Any:
    """A message of a bag; SchemaError naming the bag and the topic when it does not decode."""
    try:
        return reader.deserialize(raw, connection.msgtype)
    except AnyReaderError as error:
        raise SchemaError(f"{path}: a {connection.topic} message does not decode "
                          f"({error})") from None


def pose_series_from_messages(messages: list[Any], static_transforms: list[Any] = ()
                              ) -> PoseSeries:
    """Planar poses of ``nav_msgs/Odometry`` messages, stamped by their headers.

    ``static_transforms`` (``tf2_msgs/TFMessage``) may place the messages' ``child_frame_id``
    on the robot (``PoseSeries.reference_offset``).
    """
    if not messages:
        return PoseSeries(np.zeros(0), np.zeros((0, 3)))
    stamps = np.array([time_msg_to_stamp(msg.header.stamp) for msg in messages])
    poses = np.array([odometry_to_pose(msg) for msg in messages], dtype=float).reshape(-1, 3)
    first = messages[0]
    position_only = bool(first.pose.covariance[35] < 0.0)
    if position_only:
        poses[:, 2] = np.nan
    offset = None
    for tf_message in static_transforms:
        for transform in tf_message.transforms:
            if transform.child_frame_id == first.child_frame_id:
                offset = np.array([transform.transform.translation.x,
                                   transform.transform.translation.y])
    return PoseSeries(stamps, poses, first.header.frame_id, first.child_frame_id, position_only,
                      offset)


def read_schema_bag(path: str | Path, require_inputs: bool = True) -> SchemaBag:
    """Read a schema-v1 bag into arrays.

    A position-only ground truth reads back with ``theta`` = NaN. Raises ``SchemaError`` when
    ``/odom`` or ``/landmarks`` is missing (unless ``require_inputs`` is False, for a
    ground-truth-only bag), ``FileNotFoundError`` when ``path`` does not exist.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"bag not found: {path}")
    available = bag_topics(path)
    missing = [topic for topic in (ODOM_TOPIC, LANDMARKS_TOPIC) if topic not in available]
    if missing and require_inputs:
        raise SchemaError(f"{path}: missing topic(s) {', '.join(missing)} "
                          f"(has: {', '.join(sorted(available)) or 'none'})")
    data = read_topics(path, [ODOM_TOPIC, LANDMARKS_TOPIC, GROUND_TRUTH_POSE_TOPIC,
                              GROUND_TRUTH_LANDMARKS_TOPIC, TF_STATIC_TOPIC])
    odometry = pose_series_from_messages(data[ODOM_TOPIC][1])
    cloud_messages = data[LANDMARKS_TOPIC][1]
    scan_stamps = np.array([time_msg_to_stamp(msg.header.stamp) for msg in cloud_messages])
    points, ids = [], []
    for msg in cloud_messages:
        scan_points, scan_ids = landmark_cloud_arrays(msg)
        points.append(scan_points)
        ids.append(scan_ids)
    frame_id = cloud_messages[0].header.frame_id if cloud_messages else "sensor"
    scans = LandmarkScans(scan_stamps.reshape(-1), points, ids, frame_id)
    ground_truth = None
    if data[GROUND_TRUTH_POSE_TOPIC][1]:
        ground_truth = pose_series_from_messages(data[GROUND_TRUTH_POSE_TOPIC][1],
                                                 data[TF_STATIC_TOPIC][1])
    landmarks_truth = None
    if data[GROUND_TRUTH_LANDMARKS_TOPIC][1]:
        truth_points, truth_ids = landmark_cloud_arrays(data[GROUND_TRUTH_LANDMARKS_TOPIC][1][-1])
        landmarks_truth = LandmarkSet(truth_points.astype(float), truth_ids)
    return SchemaBag(odometry, scans, ground_truth, landmarks_truth)
