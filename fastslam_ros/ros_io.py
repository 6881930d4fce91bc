# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Conversions between ROS 2 messages and numpy arrays for the FastSLAM node.

Pure functions, no node code: the node calls them to read its inputs and to build its outputs,
and tests call them to build inputs. Input readers only use message attributes, so they accept
rclpy messages and the look-alike objects of ``rosbags`` (a replay feeds those directly).
Planar poses are ``(x, y, theta)`` arrays: metres and radians, theta wrapped to (-pi, pi].
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple, Sequence

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import (Pose, PoseArray, PoseStamped, PoseWithCovarianceStamped,
                               Quaternion, TransformStamped)
from nav_msgs.msg import Path as PathMsg
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header

from fastslam_ros.core import geometry
from fastslam_ros.map_files import LandmarkMapLike
from fastslam_ros.node_support.timing import seconds_to_nanoseconds

# sensor_msgs/PointField datatype codes -> numpy scalar types.
POINT_FIELD_DTYPES = {PointField.INT8: np.int8, PointField.UINT8: np.uint8,
                      PointField.INT16: np.int16, PointField.UINT16: np.uint16,
                      PointField.INT32: np.int32, PointField.UINT32: np.uint32,
                      PointField.FLOAT32: np.float32, PointField.FLOAT64: np.float64}
FLOAT_FIELD_TYPES = (PointField.FLOAT32, PointField.FLOAT64)
INTEGER_FIELD_TYPES = (PointField.INT8, PointField.UINT8, PointField.INT16, PointField.UINT16,
                       PointField.INT32, PointField.UINT32)

LANDMARK_CLOUD_DTYPE = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<i4")])
"""Layout of an input landmark cloud as this package writes it (x y z float32, id int32)."""
MAP_CLOUD_DTYPE = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("id", "<i4"),
                            ("cov_xx", "<f4"), ("cov_xy", "<f4"), ("cov_yy", "<f4"),
                            ("existence", "<f4")])
"""Layout of the ``~/map_cloud`` output: one point per landmark of the best particle."""



class MalformedCloudError(ValueError):
    """A PointCloud2 whose layout cannot be read (missing x/y, bad point_step or data size)."""


class InvalidQuaternionError(ValueError):
    """A quaternion with a zero norm or a non-finite component."""


class NonFiniteError(ValueError):
    """A NaN or infinite value where a number is needed."""


class InvalidStampError(ValueError):
    """A ``builtin_interfaces/Time`` outside its definition (sec < 0 or nanosec >= 1e9)."""


class MalformedScanError(ValueError):
    """A LaserScan whose geometry cannot be used (no beams, a zero or non-finite increment,
    more than a turn, an angle_max that is not the last beam's angle, NaN or crossed range
    limits, a non-finite time_increment)."""


class OversizedError(ValueError):
    """A scan or a map beyond its size cap (``max_beams_per_scan``, ``max_map_cells``)."""


ANGLE_MAX_TOLERANCE = 0.5
"""angle_max may differ by this many increments from angle_min + (n - 1) angle_increment (the
last beam's angle, REP 117's reading) or from angle_min + n angle_increment (where
pointcloud_to_laserscan puts it): the float32 fields' rounding; farther is another beam
count."""


class ScanGeometry(NamedTuple):
    """What a LaserScan says of its beams, checked (``scan_geometry``)."""

    count: int
    angle_min: float
    angle_increment: float
    range_min: float
    """At least 0."""
    range_max: float
    """inf when the scan sent 0 (a driver that leaves it unset) or inf."""
    time_increment: float


def scan_geometry(msg, max_beams: int | None = None) -> ScanGeometry:
    """The geometry of a ``sensor_msgs/LaserScan``, checked alike by every node that reads
    scans (``MalformedScanError`` naming what is wrong; ``OversizedError`` beyond
    ``max_beams``, checked before anything else is read)."""
    count = len(msg.ranges)
    if count == 0:
        raise MalformedScanError("no beams")
    if max_beams is not None and count > max_beams:
        raise OversizedError(f"{count} beams (max_beams_per_scan {max_beams})")
    increment, angle_min = float(msg.angle_increment), float(msg.angle_min)
    angle_max = float(msg.angle_max)
    if not (math.isfinite(increment) and math.isfinite(angle_min)) or increment == 0.0:
        raise MalformedScanError(f"angle_min {angle_min} / angle_increment {increment} unusable")
    if abs(increment) * (count - 1) > 2.0 * math.pi + 1e-3:
        raise MalformedScanError(f"{count} beams of {increment} rad span more than a turn")
    last = angle_min + (count - 1) * increment
    if not -ANGLE_MAX_TOLERANCE <= (angle_max - last) / increment <= 1.0 + ANGLE_MAX_TOLERANCE:
        raise MalformedScanError(f"angle_max {angle_max} is not angle_min + (n - 1) "
                                 f"angle_increment = {last} for {count} beams")
    range_min, range_max = float(msg.range_min), float(msg.range_max)
    if math.isnan(range_min) or math.isnan(range_max) or range_min == math.inf \
            or range_max < range_min:
        raise MalformedScanError(f"range_min {range_min} / range_max {range_max} unusable")
    time_increment = float(msg.time_increment)
    if not math.isfinite(time_increment):
        raise MalformedScanError(f"time_increment {time_increment} is not finite")
    return ScanGeometry(count, angle_min, increment, max(range_min, 0.0),
                        range_max if range_max > 0.0 else math.inf, time_increment)


@dataclass(frozen=True)
class LandmarkCloud:
    """Points of one landmark cloud in the sensor frame: ``x``, ``y`` (K,) m; ``ids`` (K,) or
    None when the cloud has no ``id`` field."""

    x: np.ndarray
    y: np.ndarray
    ids: np.ndarray | None


# --- time and angles ---------------------------------------------------------------------------

def stamp_to_seconds(stamp) -> float:
    """``builtin_interfaces/Time`` -> float seconds."""
    return stamp.sec + stamp.nanosec * 1e-9


def checked_stamp_to_seconds(stamp) -> float:
    """``stamp_to_seconds`` of a valid stamp; ``InvalidStampError`` for negative seconds or
    nanoseconds of 1e9 or more (which a float sum would silently turn into a later time)."""
    if stamp.sec < 0 or not 0 <= stamp.nanosec < 1_000_000_000:
        raise InvalidStampError(f"stamp sec={stamp.sec} nanosec={stamp.nanosec} is not a time "
                                "(sec >= 0, 0 <= nanosec < 1e9)")
    return stamp_to_seconds(stamp)


def seconds_to_stamp(seconds: float) -> Time:
    """Float seconds -> ``builtin_interfaces/Time`` (``seconds_to_nanoseconds``, never negative)."""
    sec, nanosec = _stamp_parts(seconds)
    return Time(sec=sec, nanosec=nanosec)


def _stamp_parts(seconds: float) -> tuple[int, int]:
    """(sec, nanosec) of ``seconds_to_stamp``."""
    return divmod(max(0, seconds_to_nanoseconds(seconds)), 1_000_000_000)


def nanoseconds_to_stamp(nanoseconds: int) -> Time:
    """Integer nanoseconds (>= 0) -> ``builtin_interfaces/Time``, as rclpy's ``Time.to_msg``."""
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def yaw_to_quaternion(yaw: float) -> Quaternion:
    """Rotation by ``yaw`` about z as a Quaternion message."""
    x, y, z, w = geometry.yaw_to_quaternion(yaw)
    return Quaternion(x=x, y=y, z=z, w=w)


def quaternion_to_yaw(q) -> float:
    """Yaw of a Quaternion message (``geometry.quaternion_to_yaw``); InvalidQuaternionError
    when it has no orientation."""
    try:
        return geometry.quaternion_to_yaw(q.x, q.y, q.z, q.w)
    except ValueError as error:
        raise InvalidQuaternionError(str(error)) from None


def odometry_pose(msg) -> np.ndarray:
    """Planar pose (3,) of a ``nav_msgs/Odometry``.

    Raises ``NonFiniteError`` for a NaN/inf position, ``InvalidQuaternionError`` for a bad
    orientation.
    """
    position = msg.pose.pose.position
    if not (math.isfinite(position.x) and math.isfinite(position.y)):
        raise NonFiniteError(f"odometry position ({position.x}, {position.y}) is not finite")
    return np.array([position.x, position.y, quaternion_to_yaw(msg.pose.pose.orientation)])


def planar_covariance(covariance: Sequence[float]) -> np.ndarray | None:
    """The (x, y, yaw) block (3, 3) of a row-major 6x6 pose covariance (a
    PoseWithCovariance's), or None when it is not finite or not positive semi-definite."""
    full = np.asarray(covariance, dtype=float).reshape(6, 6)
    planar = full[np.ix_((0, 1, 5), (0, 1, 5))]
    planar = 0.5 * (planar + planar.T)
    if not np.isfinite(planar).all() or np.linalg.eigvalsh(planar).min() < -1e-9:
        return None
    return planar


def pose_msg(pose: Sequence[float]) -> Pose:
    """Planar pose (x, y, theta) -> ``geometry_msgs/Pose`` at z = 0."""
    return _planar_pose(float(pose[0]), float(pose[1]), float(pose[2]))


def _planar_pose(x: float, y: float, yaw: float) -> Pose:
    """``pose_msg`` of floats (a PoseArray builds one per particle)."""
    pose = Pose()
    fill_pose(pose, planar_pose_view((x, y, yaw)))
    return pose


# --- point clouds ------------------------------------------------------------------------------

def read_landmark_cloud(msg) -> LandmarkCloud:
    """Read x, y (float32/64) and the optional integer ``id`` field of a landmark cloud.

    Raises ``MalformedCloudError`` when the cloud cannot be read as a whole; values inside it
    (NaN, odd ids) are returned as they are, for the caller to filter point by point. A cloud
    without points and without data is a valid empty reading (nothing seen), whatever its
    fields, so a bare ``PointCloud2()`` and one with ``width = 0`` mean the same; a cloud
    without points but with data is malformed.
    """
    count = cloud_size(msg)
    if count == 0:
        if len(msg.data):
            raise MalformedCloudError(f"width * height = 0 but {len(msg.data)} bytes of data")
        no_ids = np.zeros(0, np.int64) if any(f.name == "id" for f in msg.fields) else None
        return LandmarkCloud(np.zeros(0), np.zeros(0), no_ids)
    fields = {field.name: field for field in msg.fields}
    for name in ("x", "y"):
        if name not in fields:
            raise MalformedCloudError(f"no '{name}' field (fields: {sorted(fields)})")
        if fields[name].datatype not in FLOAT_FIELD_TYPES:
            raise MalformedCloudError(f"field '{name}' is not float32/float64")
    names = ["x", "y"]
    if "id" in fields:
        if fields["id"].datatype not in INTEGER_FIELD_TYPES:
            raise MalformedCloudError("field 'id' is not an integer type")
        names.append("id")
    point_step, row_step = msg.point_step, msg.row_step
    dtype = _point_dtype(tuple((n, fields[n].datatype, fields[n].offset) for n in names),
                         bool(msg.is_bigendian), point_step)
    if dtype is None:
        raise MalformedCloudError(f"point_step {point_step} does not hold fields {names}")
    if row_step < msg.width * point_step:
        raise MalformedCloudError(f"row_step {row_step} < width {msg.width} * "
                                  f"point_step {point_step}")
    data = np.frombuffer(msg.data, dtype=np.uint8)
    if data.size != row_step * msg.height:
        raise MalformedCloudError(f"data has {data.size} bytes, expected row_step * height = "
                                  f"{row_step * msg.height}")
    rows = data.reshape(msg.height, row_step)[:, :msg.width * point_step]
    points = np.ascontiguousarray(rows).view(dtype).reshape(-1)
    ids = points["id"].astype(np.int64) if "id" in names else None
    return LandmarkCloud(points["x"].astype(np.float64), points["y"].astype(np.float64), ids)


@functools.lru_cache(maxsize=64)
def _point_dtype(layout: tuple[tuple[str, int, int], ...], big_endian: bool,
                 point_step: int) -> np.dtype | None:
    """The structured dtype of points whose fields are ``layout`` (name, datatype, offset), or
    None when a field does not fit in ``point_step`` (a stream has one layout: cached)."""
    byte_order = ">" if big_endian else "<"
    formats = [np.dtype(POINT_FIELD_DTYPES[datatype]).newbyteorder(byte_order)
               for _, datatype, _ in layout]
    offsets = [offset for _, _, offset in layout]
    if any(offset < 0 or offset + fmt.itemsize > point_step
           for offset, fmt in zip(offsets, formats)):
        return None
    return np.dtype({"names": [name for name, _, _ in layout], "formats": formats,
                     "offsets": offsets, "itemsize": point_step})


def cloud_size(msg) -> int:
    """Number of points a PointCloud2 declares (width * height), read without its data."""
    return int(msg.width) * int(msg.height)


def _point_fields(dtype: np.dtype) -> list[PointField]:
    """PointField list describing a little-endian structured dtype of float32/int32 fields."""
    codes = {np.dtype("<f4"): PointField.FLOAT32, np.dtype("<i4"): PointField.INT32}
    return [PointField(name=name, offset=dtype.fields[name][1],
                       datatype=codes[dtype.fields[name][0]], count=1) for name in dtype.names]


def cloud_from_array(header: Header, points: np.ndarray) -> PointCloud2:
    """Unordered PointCloud2 (height 1) whose layout and bytes are those of a structured array."""
    points = np.ascontiguousarray(points)
    step = points.dtype.itemsize
    return PointCloud2(header=header, height=1, width=len(points),
                       fields=_point_fields(points.dtype), is_bigendian=False, point_step=step,
                       row_step=step * len(points), data=points.tobytes(), is_dense=True)


def landmark_cloud(header: Header, points: np.ndarray,
                   ids: np.ndarray | None = None) -> PointCloud2:
    """Input-style landmark cloud: (K, 2) points in the sensor frame, ids (K,) or -1 (unknown)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    array = np.zeros(len(points), LANDMARK_CLOUD_DTYPE)
    array["x"], array["y"] = points[:, 0], points[:, 1]
    array["id"] = -1 if ids is None else np.asarray(ids)
    return cloud_from_array(header, array)


def map_cloud(header: Header, landmark_map: LandmarkMapLike) -> PointCloud2:
    """``~/map_cloud``: landmarks with ids, covariances and existence probabilities."""
    return estimate_cloud(header, landmark_map.means, landmark_map.covariances,
                          landmark_map.existence, landmark_map.ids)


def estimate_cloud(header: Header, means: np.ndarray, covariances: np.ndarray,
                   existence: np.ndarray, ids: np.ndarray) -> PointCloud2:
    """A cloud of estimated points (``MAP_CLOUD_DTYPE``): (N, 2) means, (N, 2, 2) covariances,
    (N,) existence probabilities and ids; ``~/map_cloud`` and the tracker's ``~/people``."""
    array = np.zeros(len(means), MAP_CLOUD_DTYPE)
    array["x"], array["y"] = means[:, 0], means[:, 1]
    array["id"] = ids
    array["cov_xx"] = covariances[:, 0, 0]
    array["cov_xy"] = covariances[:, 0, 1]
    array["cov_yy"] = covariances[:, 1, 1]
    array["existence"] = existence
    return cloud_from_array(header, array)


# --- poses -------------------------------------------------------------------------------------

class VectorView(NamedTuple):
    """A ``geometry_msgs/Vector3`` (or Point) as a replay serializes it directly."""

    x: float
    y: float
    z: float


class QuaternionView(NamedTuple):
    """A ``geometry_msgs/Quaternion`` as a replay serializes it directly."""

    x: float
    y: float
    z: float
    w: float


class PoseView(NamedTuple):
    """A ``geometry_msgs/Pose`` as a replay serializes it directly."""

    position: VectorView
    orientation: QuaternionView


class _PoseWithCovariance(NamedTuple):
    pose: PoseView
    covariance: np.ndarray


class PoseWithCovarianceStampedView(NamedTuple):
    """A ``geometry_msgs/PoseWithCovarianceStamped`` as plain attributes."""

    header: Header
    pose: _PoseWithCovariance

    MSGTYPE = "geometry_msgs/msg/PoseWithCovarianceStamped"


class _Transform(NamedTuple):
    translation: VectorView
    rotation: QuaternionView


class TransformStampedView(NamedTuple):
    """A ``geometry_msgs/TransformStamped`` as plain attributes."""

    header: Header
    child_frame_id: str
    transform: _Transform

    MSGTYPE = "geometry_msgs/msg/TransformStamped"


def planar_pose_view(pose: Sequence[float]) -> PoseView:
    """Planar pose (x, y, theta) at z = 0 as plain attributes (``pose_msg``'s values)."""
    _, _, qz, qw = geometry.yaw_to_quaternion(float(pose[2]))
    return PoseView(VectorView(float(pose[0]), float(pose[1]), 0.0),
                    QuaternionView(0.0, 0.0, qz, qw))


def pose_with_covariance_view(header: Header, pose: Sequence[float],
                              covariance: np.ndarray) -> PoseWithCovarianceStampedView:
    """Planar pose with its (3, 3) covariance over (x, y, theta) placed in the 6x6 ROS layout
    (float64 (36,))."""
    full = np.zeros(36)
    full[_PLANAR_COVARIANCE] = np.ravel(covariance)
    return PoseWithCovarianceStampedView(header, _PoseWithCovariance(planar_pose_view(pose),
                                                                     full))


def pose_with_covariance(header: Header, pose: Sequence[float],
                         covariance: np.ndarray) -> PoseWithCovarianceStamped:
    """``pose_with_covariance_view`` as an rclpy message."""
    view = pose_with_covariance_view(header, pose, covariance)
    msg = PoseWithCovarianceStamped(header=header)
    fill_pose(msg.pose.pose, view.pose.pose)
    msg.pose.covariance = view.pose.covariance  # float64 (36,): taken as it is, not checked
    return msg


def fill_pose(pose: Pose, view: PoseView) -> None:
    """Set an rclpy Pose (in place: new sub-messages would build the defaults as well)."""
    position, orientation = pose.position, pose.orientation
    position.x, position.y, position.z = view.position
    orientation.x, orientation.y, orientation.z, orientation.w = view.orientation


_PLANAR = (0, 1, 5)  # x, y and rotation about z in (x, y, z, rot x, rot y, rot z)
_PLANAR_COVARIANCE = np.array([6 * row + column for row in _PLANAR for column in _PLANAR])
"""Where the (3, 3) planar covariance goes in the row-major 6x6 one."""


def pose_array(header: Header, poses: np.ndarray) -> PoseArray:
    """(M, 3) planar poses -> ``geometry_msgs/PoseArray``."""
    return PoseArray(header=header, poses=[_planar_pose(x, y, yaw) for x, y, yaw
                                           in np.asarray(poses, dtype=float).tolist()])


class PlanarPoseArray(NamedTuple):
    """The ``geometry_msgs/PoseArray`` ``pose_array(header, planar)`` kept as its header and
    (M, 3) planar poses."""

    header: Header
    planar: np.ndarray

    MSGTYPE = "geometry_msgs/msg/PoseArray"


def path(header: Header, stamps: np.ndarray, poses: np.ndarray) -> PathMsg:
    """Timed (T, 3) planar poses -> ``nav_msgs/Path``, one PoseStamped per pose."""
    return PathBuilder().build(header, stamps, poses)


class _Stamp(NamedTuple):
    sec: int
    nanosec: int


class _Header(NamedTuple):
    stamp: _Stamp
    frame_id: str


class PoseStampedView(NamedTuple):
    """A ``geometry_msgs/PoseStamped`` as plain attributes."""

    header: _Header
    pose: PoseView


class PathView(NamedTuple):
    """A ``nav_msgs/Path`` of ``PoseStampedView``."""

    header: Header
    poses: list

    MSGTYPE = "nav_msgs/msg/Path"


def pose_stamped_view(frame_id: str, stamp: float, pose: Sequence[float]) -> PoseStampedView:
    """A planar pose (x, y, theta) at ``stamp`` (s) in ``frame_id``."""
    return PoseStampedView(_Header(_Stamp(*_stamp_parts(stamp)), frame_id),
                           planar_pose_view(pose))


def pose_stamped_from_view(view: PoseStampedView) -> PoseStamped:
    """The rclpy ``PoseStamped`` of a ``PoseStampedView``."""
    msg = PoseStamped(header=Header(stamp=Time(sec=view.header.stamp.sec,
                                               nanosec=view.header.stamp.nanosec),
                                    frame_id=view.header.frame_id))
    fill_pose(msg.pose, view.pose)
    return msg


class PathBuilder:
    """Builds successive ``nav_msgs/Path`` messages of a growing trajectory.

    A PoseStamped costs ~50 us to build and a path is mostly the previous one plus new poses, so
    the PoseStamped of every (stamp, pose) still on the path is reused; a long path is then
    cheap to publish again. The reused messages are never modified. ``lean``: the poses are
    ``PoseStampedView`` and the path a ``PathView`` (what a replay serializes directly).
    """

    def __init__(self, lean: bool = False) -> None:
        self.lean = lean
        self._cache: dict[tuple[float, ...], PoseStamped | PoseStampedView] = {}

    def build(self, header: Header, stamps: np.ndarray, poses: np.ndarray) -> PathMsg:
        cache, path_poses, frame_id = {}, [], header.frame_id
        for stamp, pose in zip(np.asarray(stamps).tolist(), np.asarray(poses).tolist()):
            key = (frame_id, stamp, *pose)
            cached = self._cache.get(key)
            if cached is None:
                cached = pose_stamped_view(frame_id, stamp, pose)
                if not self.lean:
                    cached = pose_stamped_from_view(cached)
            cache[key] = cached
            path_poses.append(cached)
        self._cache = cache
        return PathView(header, path_poses) if self.lean else PathMsg(header=header,
                                                                      poses=path_poses)


def transform_view(header: Header, child_frame_id: str,
                   pose: Sequence[float]) -> TransformStampedView:
    """Planar pose of ``child_frame_id`` in ``header.frame_id`` as a transform at z = 0."""
    planar = planar_pose_view(pose)
    return TransformStampedView(header, child_frame_id,
                                _Transform(planar.position, planar.orientation))


def transform(header: Header, child_frame_id: str, pose: Sequence[float]) -> TransformStamped:
    """``transform_view`` as an rclpy ``TransformStamped``."""
    view = transform_view(header, child_frame_id, pose).transform
    msg = TransformStamped(header=header, child_frame_id=child_frame_id)
    translation, rotation = msg.transform.translation, msg.transform.rotation
    translation.x, translation.y, translation.z = view.translation
    rotation.x, rotation.y, rotation.z, rotation.w = view.rotation
    return msg
