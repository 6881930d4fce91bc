# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Direct CDR readers and writers of the replay against rclpy's and rosbags' serializers."""
from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PoseArray, PoseWithCovarianceStamped, TransformStamped
from hypothesis import given, settings
from hypothesis import strategies as st
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as PathMsg
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray, UVCoordinate

from fastslam_ros import ros_io
from fastslam_ros.tools.bags import cdr
from fastslam_ros.tools.bags.bag_schema import TYPESTORE

FRAMES = st.sampled_from(["", "odom", "base_link", "a_frame_with_a_longer_name", "kart\u00e9"])
FLOATS = st.floats(allow_nan=False, allow_infinity=False, width=64)
UNIT = st.floats(0.0, 1.0, width=32)
STAMPS = st.tuples(st.integers(0, 2**31 - 1), st.integers(0, 999_999_999))


def canonical(msg, msgtype: str) -> bytes:
    """rclpy's bytes of ``msg`` as rosbags writes them (rclpy leaves padding undefined)."""
    return bytes(TYPESTORE.serialize_cdr(
        TYPESTORE.deserialize_cdr(serialize_message(msg), msgtype), msgtype))


def header(stamp, frame: str) -> Header:
    return Header(stamp=Time(sec=stamp[0], nanosec=stamp[1]), frame_id=frame)


# --- readers -----------------------------------------------------------------------------------

@settings(max_examples=100, deadline=None)
@given(STAMPS, FRAMES, FRAMES, st.lists(FLOATS, min_size=7, max_size=7))
def test_odometry_read_directly_is_rclpys(stamp, frame, child, values):
    msg = Odometry(header=header(stamp, frame), child_frame_id=child)
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y, p.z, q.x, q.y, q.z, q.w = values
    msg.twist.twist.linear.x = 3.0
    view = cdr.read_odometry(serialize_message(msg))
    assert view is not None
    assert (view.header.stamp.sec, view.header.stamp.nanosec) == stamp
    assert (view.header.frame_id, view.child_frame_id) == (frame, child)
    got = view.pose.pose
    assert [*got.position, *got.orientation] == values
    assert pose_or_error(view) == pose_or_error(msg)


def test_odometry_frames_read_again_only_when_their_bytes_change():
    """A stream of odometry read directly: the frames of the previous message are reused only
    for bytes that are the same there; any other message reads as rclpy reads it."""
    stream = []
    for index, (frame, child) in enumerate([("odom", "base_link")] * 3 + [
            ("odom", "base_lint"), ("odom", "base_link"), ("", "base_link"), ("map", ""),
            ("a_frame_with_a_longer_name", "base_link"), ("odom", "base_link")]):
        msg = Odometry(header=header((index, 1000 * index), frame), child_frame_id=child)
        msg.pose.pose.position.x, msg.pose.pose.orientation.w = float(index), 1.0
        stream.append(serialize_message(msg))
    truncated = stream[1][:-8]  # the same frame bytes, too short
    stream.insert(2, truncated)
    for raw in stream:
        view = cdr.read_odometry(raw)
        if raw is truncated:
            assert view is None
            continue
        msg = deserialize_message(raw, Odometry)
        assert (view.header.stamp.sec, view.header.stamp.nanosec, view.header.frame_id,
                view.child_frame_id) == (msg.header.stamp.sec, msg.header.stamp.nanosec,
                                         msg.header.frame_id, msg.child_frame_id)
        assert view.pose.pose.position.x == msg.pose.pose.position.x


@settings(max_examples=100, deadline=None)
@given(STAMPS, FRAMES, FRAMES, st.lists(FLOATS, min_size=7, max_size=7))
def test_odometry_transform_from_the_bytes_is_the_one_from_the_message(stamp, frame, child,
                                                                        values):
    msg = Odometry(header=header(stamp, frame), child_frame_id=child)
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y, p.z, q.x, q.y, q.z, q.w = values
    raw = serialize_message(msg)
    view = cdr.read_odometry(raw)
    assert cdr.odometry_tf_cdr(raw, "odom", "base_link") == cdr.tf_message_cdr(
        *stamp, frame or "odom", child or "base_link", values[:3], values[3:])
    assert cdr.read_odometry(raw[:-1]) is None
    assert cdr.odometry_tf_cdr(raw[:-1], "odom", "base_link") is None  # not read: no bytes
    other = Odometry(header=header(stamp, frame + "x"), child_frame_id=child)
    assert cdr.odometry_tf_cdr(serialize_message(other), "odom", "base_link") is None
    assert view is not None


def pose_or_error(msg):
    try:
        return ros_io.odometry_pose(msg).tolist()
    except ValueError as error:
        return str(error)


FIELDS = st.lists(st.builds(lambda name, offset, datatype, count: PointField(
    name=name, offset=offset, datatype=datatype, count=count),
    st.sampled_from(["x", "y", "z", "id", "intensity"]), st.integers(0, 24), st.integers(0, 9),
    st.integers(0, 2)), max_size=6)


@st.composite
def clouds(draw) -> PointCloud2:
    """PointCloud2 messages of random layouts, readable or not (as test_faults draws them)."""
    width, height = draw(st.integers(0, 6)), draw(st.integers(0, 3))
    point_step = draw(st.integers(0, 24))
    row_step = draw(st.one_of(st.just(width * point_step), st.integers(0, 160)))
    size = draw(st.one_of(st.just(row_step * height), st.integers(0, 400)))
    return PointCloud2(header=header(draw(STAMPS), draw(FRAMES)), height=height, width=width,
                       fields=draw(FIELDS), is_bigendian=draw(st.booleans()),
                       point_step=point_step, row_step=row_step,
                       data=draw(st.binary(min_size=size, max_size=size)),
                       is_dense=draw(st.booleans()))


def read_or_error(msg):
    try:
        cloud = ros_io.read_landmark_cloud(msg)
    except ros_io.MalformedCloudError as error:
        return str(error)
    return cloud.x.tobytes(), cloud.y.tobytes(), None if cloud.ids is None else cloud.ids.tolist()


@settings(max_examples=200, deadline=None)
@given(clouds())
def test_cloud_read_directly_is_rclpys_and_the_node_reads_it_the_same(msg):
    view = cdr.read_point_cloud(serialize_message(msg))
    assert view is not None
    assert (view.header.stamp.sec, view.header.stamp.nanosec, view.header.frame_id) == \
        (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id)
    assert (view.height, view.width, view.is_bigendian, view.point_step, view.row_step,
            view.is_dense) == (msg.height, msg.width, msg.is_bigendian, msg.point_step,
                               msg.row_step, msg.is_dense)
    assert [tuple(f) for f in view.fields] == [(f.name, f.offset, f.datatype, f.count)
                                              for f in msg.fields]
    assert bytes(view.data) == bytes(msg.data)
    assert read_or_error(view) == read_or_error(msg)


def test_what_the_readers_do_not_read_exactly_goes_the_generic_way():
    odometry = serialize_message(Odometry(header=Header(frame_id="odom")))
    cloud = serialize_message(ros_io.landmark_cloud(Header(frame_id="laser"), [[1.0, 2.0]]))
    assert cdr.read_odometry(odometry) is not None and cdr.read_point_cloud(cloud) is not None
    big_endian = b"\x00\x00\x00\x00"
    for raw, read in ((odometry, cdr.read_odometry), (cloud, cdr.read_point_cloud)):
        assert read(big_endian + raw[4:]) is None
        assert read(raw[:-9]) is None                 # truncated
        assert read(raw[:16]) is None
    assert cdr.read_odometry(odometry + bytes(8)) is None  # longer than an Odometry
    no_nul = bytearray(odometry)
    no_nul[16 + 4] = ord("x")  # "odom\0" -> "odomx"
    assert cdr.read_odometry(bytes(no_nul)) is None
    not_utf8 = bytearray(odometry)
    not_utf8[16] = 0xff
    assert cdr.read_odometry(bytes(not_utf8)) is None
    inner_nul = bytearray(odometry)
    inner_nul[16 + 3] = 0  # "odom\0" -> "odo\0\0": rclpy reads "odo"
    assert cdr.read_odometry(bytes(inner_nul)) is None


def test_every_truncation_of_a_message_goes_the_generic_way():
    """No prefix of a serialized odometry or cloud message raises: the readers return None."""
    odometry = serialize_message(Odometry(header=Header(frame_id="odom"), child_frame_id="base"))
    cloud = serialize_message(ros_io.landmark_cloud(Header(frame_id="laser"), [[1.0, 2.0]]))
    for raw, read in ((odometry, cdr.read_odometry), (cloud, cdr.read_point_cloud)):
        assert all(read(raw[:size]) is None for size in range(len(raw)))


# --- writers -----------------------------------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(STAMPS, FRAMES, FRAMES, st.lists(FLOATS, min_size=7 + 36, max_size=7 + 36))
def test_pose_and_transform_written_directly_are_the_serializers(stamp, frame, child, values):
    pose = PoseWithCovarianceStamped(header=header(stamp, frame))
    p, q = pose.pose.pose.position, pose.pose.pose.orientation
    p.x, p.y, p.z, q.x, q.y, q.z, q.w = values[:7]
    pose.pose.covariance = np.array(values[7:])
    assert cdr.pose_with_covariance_stamped_cdr(pose) == \
        canonical(pose, "geometry_msgs/msg/PoseWithCovarianceStamped")
    transform = TransformStamped(header=header(stamp, frame), child_frame_id=child)
    t, r = transform.transform.translation, transform.transform.rotation
    t.x, t.y, t.z, r.x, r.y, r.z, r.w = values[:7]
    assert cdr.transform_stamped_cdr(transform) == \
        canonical(transform, "geometry_msgs/msg/TransformStamped")


@settings(max_examples=60, deadline=None)
@given(STAMPS, FRAMES, FRAMES, st.tuples(FLOATS, FLOATS, st.floats(-10.0, 10.0)),
       st.lists(FLOATS, min_size=9, max_size=9))
def test_pose_and_transform_views_written_directly_are_the_rclpy_messages(stamp, frame, child,
                                                                           pose, covariance):
    """A replay's node hands ~/pose and ~/map_to_odom over as views (``in_process``, lean)."""
    covariance = np.array(covariance).reshape(3, 3)
    view = ros_io.pose_with_covariance_view(header(stamp, frame), pose, covariance)
    assert isinstance(view, ros_io.PoseWithCovarianceStampedView)
    assert cdr.pose_with_covariance_stamped_cdr(view) == canonical(
        ros_io.pose_with_covariance(view.header, pose, covariance),
        "geometry_msgs/msg/PoseWithCovarianceStamped")
    view = ros_io.transform_view(header(stamp, frame), child, pose)
    assert isinstance(view, ros_io.TransformStampedView)
    assert cdr.transform_stamped_cdr(view) == canonical(
        ros_io.transform(view.header, child, pose), "geometry_msgs/msg/TransformStamped")


@settings(max_examples=60, deadline=None)
@given(STAMPS, FRAMES, st.lists(st.tuples(FLOATS, FLOATS, FLOATS), max_size=12))
def test_pose_array_written_directly_is_the_serializers(stamp, frame, poses):
    msg = ros_io.pose_array(header(stamp, frame), np.array(poses).reshape(-1, 3))
    assert cdr.pose_array_cdr(msg) == canonical(msg, "geometry_msgs/msg/PoseArray")


@settings(max_examples=100, deadline=None)
@given(clouds())
def test_cloud_written_directly_is_the_serializers(msg):
    assert cdr.point_cloud2_cdr(msg) == canonical(msg, "sensor_msgs/msg/PointCloud2")
    assert cdr.point_cloud2_cdr(cdr.read_point_cloud(serialize_message(msg))) == \
        canonical(msg, "sensor_msgs/msg/PointCloud2")


@settings(max_examples=60, deadline=None)
@given(STAMPS, FRAMES, st.lists(st.tuples(st.integers(0, 3), FRAMES, FRAMES, st.lists(
    st.tuples(FRAMES, FRAMES), max_size=4)), max_size=3))
def test_diagnostics_written_directly_are_the_serializers(stamp, frame, statuses):
    msg = DiagnosticArray(header=header(stamp, frame), status=[
        DiagnosticStatus(level=bytes((level,)), name=name, message=message,
                         hardware_id=name + message,
                         values=[KeyValue(key=k, value=v) for k, v in values])
        for level, name, message, values in statuses])
    assert cdr.diagnostic_array_cdr(msg) == canonical(msg, "diagnostic_msgs/msg/DiagnosticArray")


def test_paths_from_cached_pieces_are_the_serializers():
    """A growing, decimated path whose poses are reused (PathBuilder) and whose header changes
    length, so reused poses are met at both alignments."""
    rng = np.random.default_rng(5)
    builder, writer = ros_io.PathBuilder(), cdr.SequenceCdr("poses", cdr.pose_stamped_piece,
                                                            has_header=True)
    lean_builder, lean_writer = ros_io.PathBuilder(lean=True), cdr.SequenceCdr(
        "poses", cdr.pose_stamped_piece, has_header=True)
    stamps, poses = np.zeros(0), np.zeros((0, 3))
    for step, frame in enumerate(["map", "m", "map_frame", "", "map"] * 3):
        stamps = np.append(stamps, 10.0 + step * 0.37)
        poses = np.vstack([poses, rng.normal(0.0, 10.0, (1, 3))])
        keep = slice(None) if step % 4 else slice(step % 3, None)
        msg = builder.build(header((step, 7 * step), frame), stamps[keep], poses[keep])
        assert writer.serialize(msg) == canonical(msg, "nav_msgs/msg/Path")
        lean = lean_builder.build(header((step, 7 * step), frame), stamps[keep], poses[keep])
        assert isinstance(lean, ros_io.PathView)
        assert lean_writer.serialize(lean) == writer.serialize(msg)  # a replay's ~/path
    assert isinstance(msg, PathMsg) and deserialize_message(writer.serialize(msg), PathMsg) == msg


@pytest.mark.parametrize("poses", [np.zeros((0, 3)), np.array([[1.0, -2.0, 3.0]])])
def test_empty_and_single_pose_arrays(poses):
    msg = ros_io.pose_array(Header(frame_id="map"), poses)
    assert isinstance(msg, PoseArray)
    assert cdr.pose_array_cdr(msg) == canonical(msg, "geometry_msgs/msg/PoseArray")


def markers(draw) -> Marker:
    """Markers with every field set, sequences empty or not."""
    msg = Marker(header=header(draw(STAMPS), draw(FRAMES)), ns=draw(FRAMES),
                 id=draw(st.integers(-2**31, 2**31 - 1)), type=draw(st.integers(0, 11)),
                 action=draw(st.integers(0, 3)), text=draw(FRAMES),
                 frame_locked=draw(st.booleans()), texture_resource=draw(FRAMES),
                 mesh_resource=draw(FRAMES), mesh_use_embedded_materials=draw(st.booleans()))
    (msg.pose.position.x, msg.pose.position.y, msg.pose.position.z, msg.pose.orientation.x,
     msg.pose.orientation.y, msg.pose.orientation.z, msg.pose.orientation.w,
     msg.scale.x, msg.scale.y, msg.scale.z) = draw(st.lists(FLOATS, min_size=10, max_size=10))
    msg.color = ColorRGBA(**dict(zip("rgba", draw(st.lists(UNIT, min_size=4, max_size=4)))))
    msg.lifetime.sec, msg.lifetime.nanosec = draw(STAMPS)
    msg.points = [Point(x=x, y=y, z=z) for x, y, z in draw(
        st.lists(st.tuples(FLOATS, FLOATS, FLOATS), max_size=3))]
    msg.colors = [ColorRGBA(r=r, a=a) for r, a in draw(st.lists(st.tuples(UNIT, UNIT),
                                                                 max_size=3))]
    msg.uv_coordinates = [UVCoordinate(u=u, v=v) for u, v in draw(
        st.lists(st.tuples(UNIT, UNIT), max_size=2))]
    msg.texture.header = header(draw(STAMPS), draw(FRAMES))
    msg.texture.format = draw(FRAMES)
    msg.texture.data = draw(st.lists(st.integers(0, 255), max_size=5))
    msg.mesh_file.filename = draw(FRAMES)
    msg.mesh_file.data = draw(st.lists(st.integers(0, 255), max_size=5))
    return msg


@settings(max_examples=100, deadline=None)
@given(st.composite(markers)(), st.sampled_from([0, 4]))
def test_marker_written_directly_is_the_serializers(msg, alignment):
    """A Marker alone (payload offset 0 modulo 8) and first in a MarkerArray (4)."""
    if alignment == 0:
        expected = canonical(msg, "visualization_msgs/msg/Marker")[4:]
    else:
        expected = canonical(MarkerArray(markers=[msg]), "visualization_msgs/msg/MarkerArray")[8:]
    assert cdr.marker_piece(msg, alignment) == expected


@settings(max_examples=100, deadline=None)
@given(STAMPS, FRAMES, st.lists(st.tuples(FLOATS, FLOATS, st.floats(-10.0, 10.0)), max_size=5))
def test_planar_pose_array_written_directly_is_the_pose_arrays(stamp, frame, poses):
    msg = ros_io.PlanarPoseArray(header(stamp, frame), np.array(poses).reshape(-1, 3))
    assert cdr.planar_pose_array_cdr(msg) == canonical(ros_io.pose_array(msg.header, msg.planar),
                                                       "geometry_msgs/msg/PoseArray")
