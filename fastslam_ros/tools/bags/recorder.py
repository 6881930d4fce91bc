# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""What a replay writes: the node's outputs and the copied inputs into an MCAP bag at bag time
(OutputRecorder), the frequent outputs serialized directly, byte for byte as rosbags writes
them (tools/bags/cdr.py), and rosbags' MCAP writer with each record written in one piece
(LeanMcapWriter)."""
from __future__ import annotations

import struct
from importlib.metadata import version
from typing import Any
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Path as PathMsg
from rclpy.serialization import serialize_message
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                QosTime)
from rosbags.rosbag2 import CompressionMode, StoragePlugin, Writer
from rosbags.rosbag2.storage_mcap import McapWriter
from sensor_msgs.msg import PointCloud2
from visualization_msgs.msg import MarkerArray

from fastslam_ros.ros_io import (PathView, PlanarPoseArray, PoseWithCovarianceStampedView,
                                 TransformStampedView)
from fastslam_ros.ros_markers import MarkerArrayView
from fastslam_ros.tools.bags.cdr import (SequenceCdr, diagnostic_array_cdr, marker_piece,
                                         odometry_tf_cdr, planar_pose_array_cdr, point_cloud2_cdr,
                                         pose_array_cdr, pose_stamped_piece,
                                         pose_with_covariance_stamped_cdr, tf_message_cdr,
                                         transform_stamped_cdr)
from fastslam_ros.tools.bags.bag_schema import TF_STATIC_TOPIC, TF_TYPE, TYPESTORE, tf_message_bytes


TF_TOPIC = "/tf"


STATIC_QOS = [Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL,
                  QosTime(0, 0), QosTime(0, 0), QosLiveliness.AUTOMATIC, QosTime(0, 0), False)]


"""QoS recorded for ``/tf_static``: latched, as tf2's static broadcaster offers it."""


LOOK_ALIKES = (PlanarPoseArray, MarkerArrayView, PoseWithCovarianceStampedView,
               TransformStampedView, PathView)


"""A replay node's look-alike outputs (``in_process``, lean), each naming its type (``MSGTYPE``)."""


TRANSFORMS = (TransformStamped, TransformStampedView)


"""Outputs that also go to ``/tf``."""


DIRECT_WRITERS = {TransformStamped: transform_stamped_cdr,
                  TransformStampedView: transform_stamped_cdr,
                  PoseWithCovarianceStamped: pose_with_covariance_stamped_cdr,
                  PoseWithCovarianceStampedView: pose_with_covariance_stamped_cdr,
                  PoseArray: pose_array_cdr, PointCloud2: point_cloud2_cdr,
                  DiagnosticArray: diagnostic_array_cdr, PlanarPoseArray: planar_pose_array_cdr}


"""Output types serialized directly (rclpy's serializer costs about 6 us per pose)."""


def ros_msgtype(msg: Any) -> str:
    """``pkg/msg/Name`` of an rclpy message instance (or the ``MSGTYPE`` of a look-alike)."""
    if isinstance(msg, LOOK_ALIKES):
        return msg.MSGTYPE
    package = type(msg).__module__.split(".")[0]
    return f"{package}/msg/{type(msg).__name__}"


class MarkerArrayCdr(SequenceCdr):
    """``visualization_msgs/MarkerArray`` from pieces (``SequenceCdr``)."""

    def __init__(self) -> None:
        super().__init__("markers", marker_piece, has_header=False)


class PathCdr(SequenceCdr):
    """``nav_msgs/Path`` from pieces (``SequenceCdr``)."""

    def __init__(self) -> None:
        super().__init__("poses", pose_stamped_piece, has_header=True)


SEQUENCE_WRITERS = {MarkerArray: MarkerArrayCdr, MarkerArrayView: MarkerArrayCdr, PathMsg: PathCdr,
                    PathView: PathCdr}


"""Output types serialized from the pieces of their reused sub-messages, one writer a topic."""


class LeanMcapWriter(McapWriter):
    """rosbags' MCAP storage writer with a message record written in one piece.

    A replay writes about 160,000 small messages; rosbags builds each record from a buffer of
    its own and six small writes. The bytes, the chunking and the indexes are rosbags' own
    (``test_replay`` compares the files)."""

    _RECORD = struct.Struct("<BQHIQQ")
    """Message record: opcode 0x05, length, channel id, sequence 0, log and publish time."""

    def write(self, connection: Any, timestamp: int, data: bytes | memoryview) -> None:
        if timestamp < self.message_start_time:
            self.message_start_time = timestamp
        if timestamp > self.message_end_time:
            self.message_end_time = timestamp
        self.channel_stats[connection.id] += 1
        chunk = self.chunk
        if timestamp < chunk.message_start_time:
            chunk.message_start_time = timestamp
        if timestamp > chunk.message_end_time:
            chunk.message_end_time = timestamp
        stream = chunk.bio
        chunk.msgs[connection.id].append((timestamp, stream.tell()))
        stream.write(self._RECORD.pack(0x05, 22 + len(data), connection.id, 0, timestamp,
                                       timestamp))
        stream.write(data)
        if stream.tell() > 2**20:
            self.close_chunk()


LEAN_WRITER_ROSBAGS = ("0.11.",)


"""rosbags releases whose MCAP writer internals ``LeanMcapWriter`` was checked against; with
any other the replay records through rosbags' own writer."""


def lean_writer(writer: Writer) -> Writer:
    """``writer`` (not yet open) with ``LeanMcapWriter`` as its MCAP storage, when rosbags'
    storage is the one it derives from, in a release it was checked against."""
    if (Writer.STORAGE_PLUGINS.get(StoragePlugin.MCAP) is McapWriter
            and version("rosbags").startswith(LEAN_WRITER_ROSBAGS)):
        writer.STORAGE_PLUGINS = {**Writer.STORAGE_PLUGINS, StoragePlugin.MCAP: LeanMcapWriter}
    return writer


class OutputRecorder:
    """Writes node outputs and copied inputs into an MCAP bag at the current bag time."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.connections: dict[str, Any] = {}
        self.stamp_ns = 0
        self._sequences: dict[str, SequenceCdr] = {}
        self._write = writer.write
        if type(writer.storage) is LeanMcapWriter and writer.compression_mode != \
                CompressionMode.MESSAGE:
            self._write = self._write_lean

    def _write_lean(self, connection: Any, timestamp: int, data: bytes) -> None:
        """``Writer.write`` without its checks (the recorder writes only to the connections it
        added; rosbags looks each up in a list, comparing every field)."""
        writer = self.writer
        writer.storage.write(connection, timestamp, data)
        writer.counts[connection.id] += 1
        if timestamp < writer.min_timestamp:
            writer.min_timestamp = timestamp
        if timestamp > writer.max_timestamp:
            writer.max_timestamp = timestamp

    def _connection(self, topic: str, msgtype: str) -> Any:
        connection = self.connections.get(topic)
        if connection is None:
            qos = STATIC_QOS if topic == TF_STATIC_TOPIC else ()
            connection = self.connections[topic] = self.writer.add_connection(
                topic, msgtype, typestore=TYPESTORE, offered_qos_profiles=qos)
        return connection

    def record(self, topic: str, msg: Any) -> None:
        """Output listener of the node: serialize the rclpy message and write it; the node's
        map -> odom transform also goes to ``/tf``."""
        direct, sequence = DIRECT_WRITERS.get(type(msg)), SEQUENCE_WRITERS.get(type(msg))
        if direct is not None:
            raw = direct(msg)
        elif sequence is not None:
            writer = self._sequences.get(topic) or self._sequences.setdefault(topic, sequence())
            raw = writer.serialize(msg)
        else:
            raw = serialize_message(msg)
        connection = self.connections.get(topic) or self._connection(topic, ros_msgtype(msg))
        self._write(connection, self.stamp_ns, raw)
        if type(msg) in TRANSFORMS:
            translation, rotation = msg.transform.translation, msg.transform.rotation
            stamp = msg.header.stamp
            self.copy(TF_TOPIC, TF_TYPE, self.stamp_ns, tf_message_cdr(
                stamp.sec, stamp.nanosec, msg.header.frame_id, msg.child_frame_id,
                (translation.x, translation.y, translation.z),
                (rotation.x, rotation.y, rotation.z, rotation.w)))

    def copy(self, topic: str, msgtype: str, stamp_ns: int, raw: bytes) -> None:
        """Write an input message unchanged."""
        self._write(self.connections.get(topic) or self._connection(topic, msgtype), stamp_ns,
                    raw)

    def tf(self, topic: str, transforms: list[Any]) -> None:
        """Write rosbags ``TransformStamped`` messages as one ``TFMessage`` on ``topic``."""
        self.copy(topic, TF_TYPE, self.stamp_ns, tf_message_bytes(transforms))

    def odometry_tf(self, msg: Any, raw: bytes, odom_frame: str, base_frame: str) -> None:
        """``/tf`` odom -> base_link of an odometry message the node used (so valid): from its
        bytes when ``read_odometry`` read them, else from the message."""
        data = odometry_tf_cdr(raw, odom_frame, base_frame)
        if data is None:
            pose, stamp = msg.pose.pose, msg.header.stamp
            p, q = pose.position, pose.orientation
            data = tf_message_cdr(stamp.sec, stamp.nanosec, msg.header.frame_id or odom_frame,
                                  msg.child_frame_id or base_frame, (p.x, p.y, p.z),
                                  (q.x, q.y, q.z, q.w))
        self.copy(TF_TOPIC, TF_TYPE, self.stamp_ns, data)
