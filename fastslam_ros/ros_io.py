"""Conversions between ROS 2 messages and numpy arrays for the FastSLAM node.

Pure functions, no node code: the node calls them to read its inputs and to build its outputs,
and tests call them to build inputs. Input readers only use message attributes, so they accept
rclpy messages and the look-alike objects of ``rosbags`` (a replay feeds those directly).
Planar poses are ``(x, y, theta)`` arrays: metres and radians, theta wrapped to (-pi, pi].
"""
from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, Sequence

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import (Point, Pose, PoseArray, PoseStamped, PoseWithCovarianceStamped,
                               Quaternion, TransformStamped)
from nav_msgs.msg import Path as PathMsg
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from fastslam_ros.core.geometry import wrap_angle
from fastslam_ros.core.timing import seconds_to_nanoseconds

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

ELLIPSE_NAMESPACE = "covariance"
LABEL_NAMESPACE = "id"
ELLIPSE_SIGMA = 2.0
"""Covariance ellipses are drawn at 2 sigma (86 % of the probability mass in 2-D)."""
ELLIPSE_HEIGHT = 0.02
LABEL_HEIGHT = 0.3
LABEL_LIFT = 0.3
MIN_MARKER_SCALE = 1e-3
"""RViz refuses markers with a zero scale; a collapsed ellipse is drawn this thin instead (m)."""
MAP_FILE_COLUMNS = ("key", "id", "x", "y", "cov_xx", "cov_xy", "cov_yy", "existence")


class MalformedCloudError(ValueError):
    """A PointCloud2 whose layout cannot be read (missing x/y, bad point_step or data size)."""


class InvalidQuaternionError(ValueError):
    """A quaternion with a zero norm or a non-finite component."""


class NonFiniteError(ValueError):
    """A NaN or infinite value where a number is needed."""


class LandmarkMapLike(Protocol):
    """What the converters need of ``fastslam_ros.core.LandmarkMap``."""

    means: np.ndarray
    covariances: np.ndarray
    existence: np.ndarray
    ids: np.ndarray
    keys: np.ndarray


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


def seconds_to_stamp(seconds: float) -> Time:
    """Float seconds -> ``builtin_interfaces/Time`` (``seconds_to_nanoseconds``, never negative)."""
    nanoseconds = max(0, seconds_to_nanoseconds(seconds))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def yaw_to_quaternion(yaw: float) -> Quaternion:
    """Rotation by ``yaw`` about z as a unit quaternion."""
    return Quaternion(z=math.sin(0.5 * yaw), w=math.cos(0.5 * yaw))


def quaternion_to_yaw(q) -> float:
    """Yaw (rotation about z, in (-pi, pi]) of any non-zero quaternion; roll and pitch dropped."""
    x, y, z, w = q.x, q.y, q.z, q.w
    norm_squared = x * x + y * y + z * z + w * w
    if not math.isfinite(norm_squared) or norm_squared < 1e-12:
        raise InvalidQuaternionError(f"quaternion ({x}, {y}, {z}, {w}) has no orientation")
    return wrap_angle(math.atan2(2.0 * (w * z + x * y), norm_squared - 2.0 * (y * y + z * z)))


def odometry_pose(msg) -> np.ndarray:
    """Planar pose (3,) of a ``nav_msgs/Odometry``.

    Raises ``NonFiniteError`` for a NaN/inf position, ``InvalidQuaternionError`` for a bad
    orientation.
    """
    position = msg.pose.pose.position
    if not (math.isfinite(position.x) and math.isfinite(position.y)):
        raise NonFiniteError(f"odometry position ({position.x}, {position.y}) is not finite")
    return np.array([position.x, position.y, quaternion_to_yaw(msg.pose.pose.orientation)])


def pose_msg(pose: Sequence[float]) -> Pose:
    """Planar pose (x, y, theta) -> ``geometry_msgs/Pose`` at z = 0."""
    return Pose(position=Point(x=float(pose[0]), y=float(pose[1])),
                orientation=yaw_to_quaternion(float(pose[2])))


# --- point clouds ------------------------------------------------------------------------------

def read_landmark_cloud(msg) -> LandmarkCloud:
    """Read x, y (float32/64) and the optional integer ``id`` field of a landmark cloud.

    Raises ``MalformedCloudError`` when the cloud cannot be read as a whole; values inside it
    (NaN, odd ids) are returned as they are, for the caller to filter point by point.
    """
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
    count = msg.width * msg.height
    if count == 0:
        no_ids = np.zeros(0, np.int64) if "id" in names else None
        return LandmarkCloud(np.zeros(0), np.zeros(0), no_ids)
    point_step, row_step = msg.point_step, msg.row_step
    byte_order = ">" if msg.is_bigendian else "<"
    formats = [np.dtype(POINT_FIELD_DTYPES[fields[n].datatype]).newbyteorder(byte_order)
               for n in names]
    offsets = [fields[n].offset for n in names]
    if any(offset < 0 or offset + fmt.itemsize > point_step
           for offset, fmt in zip(offsets, formats)):
        raise MalformedCloudError(f"point_step {point_step} does not hold fields {names}")
    if row_step < msg.width * point_step:
        raise MalformedCloudError(f"row_step {row_step} < width {msg.width} * "
                                  f"point_step {point_step}")
    data = np.frombuffer(msg.data, dtype=np.uint8)
    if data.size != row_step * msg.height:
        raise MalformedCloudError(f"data has {data.size} bytes, expected row_step * height = "
                                  f"{row_step * msg.height}")
    rows = data.reshape(msg.height, row_step)[:, :msg.width * point_step]
    dtype = np.dtype({"names": names, "formats": formats, "offsets": offsets,
                      "itemsize": point_step})
    points = np.ascontiguousarray(rows).view(dtype).reshape(-1)
    ids = points["id"].astype(np.int64) if "id" in names else None
    return LandmarkCloud(points["x"].astype(np.float64), points["y"].astype(np.float64), ids)


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
    array = np.zeros(len(landmark_map.means), MAP_CLOUD_DTYPE)
    array["x"], array["y"] = landmark_map.means[:, 0], landmark_map.means[:, 1]
    array["id"] = landmark_map.ids
    array["cov_xx"] = landmark_map.covariances[:, 0, 0]
    array["cov_xy"] = landmark_map.covariances[:, 0, 1]
    array["cov_yy"] = landmark_map.covariances[:, 1, 1]
    array["existence"] = landmark_map.existence
    return cloud_from_array(header, array)


# --- poses -------------------------------------------------------------------------------------

def pose_with_covariance(header: Header, pose: Sequence[float],
                         covariance: np.ndarray) -> PoseWithCovarianceStamped:
    """Planar pose with its (3, 3) covariance over (x, y, theta) placed in the 6x6 ROS layout."""
    msg = PoseWithCovarianceStamped(header=header)
    msg.pose.pose = pose_msg(pose)
    full = np.zeros((6, 6))
    planar = [0, 1, 5]  # x, y and rotation about z in (x, y, z, rot x, rot y, rot z)
    full[np.ix_(planar, planar)] = covariance
    msg.pose.covariance = full.ravel().tolist()
    return msg


def pose_array(header: Header, poses: np.ndarray) -> PoseArray:
    """(M, 3) planar poses -> ``geometry_msgs/PoseArray``."""
    return PoseArray(header=header, poses=[pose_msg(pose) for pose in poses])


def path(header: Header, stamps: np.ndarray, poses: np.ndarray) -> PathMsg:
    """Timed (T, 3) planar poses -> ``nav_msgs/Path``, one PoseStamped per pose."""
    return PathBuilder().build(header, stamps, poses)


class PathBuilder:
    """Builds successive ``nav_msgs/Path`` messages of a growing trajectory.

    A PoseStamped costs ~50 us to build and a path is mostly the previous one plus new poses, so
    the PoseStamped of every (stamp, pose) still on the path is reused; a long path is then
    cheap to publish again. The reused messages are never modified.
    """

    def __init__(self) -> None:
        self._cache: dict[tuple[float, ...], PoseStamped] = {}

    def build(self, header: Header, stamps: np.ndarray, poses: np.ndarray) -> PathMsg:
        cache, path_poses = {}, []
        for stamp, pose in zip(np.asarray(stamps).tolist(), np.asarray(poses).tolist()):
            key = (header.frame_id, stamp, *pose)
            cached = self._cache.get(key) or PoseStamped(
                header=Header(stamp=seconds_to_stamp(stamp), frame_id=header.frame_id),
                pose=pose_msg(pose))
            cache[key] = cached
            path_poses.append(cached)
        self._cache = cache
        return PathMsg(header=header, poses=path_poses)


def transform(header: Header, child_frame_id: str, pose: Sequence[float]) -> TransformStamped:
    """Planar pose of ``child_frame_id`` in ``header.frame_id`` -> ``TransformStamped``."""
    msg = TransformStamped(header=header, child_frame_id=child_frame_id)
    msg.transform.translation.x, msg.transform.translation.y = float(pose[0]), float(pose[1])
    msg.transform.rotation = yaw_to_quaternion(float(pose[2]))
    return msg


# --- markers -----------------------------------------------------------------------------------

def ellipse_axes(covariances: np.ndarray, sigma: float = ELLIPSE_SIGMA):
    """Diameters (N,), (N,) along the major and minor axes and the major axis angle (N,)."""
    eigenvalues, eigenvectors = np.linalg.eigh(covariances)  # ascending eigenvalues
    diameters = 2.0 * sigma * np.sqrt(np.clip(eigenvalues, 0.0, None))
    diameters = np.maximum(diameters, MIN_MARKER_SCALE)
    angles = np.arctan2(eigenvectors[:, 1, 1], eigenvectors[:, 0, 1])
    return diameters[:, 1], diameters[:, 0], angles


def landmark_markers(header: Header, landmark_map: LandmarkMapLike,
                     removed_keys: Sequence[int] = ()) -> MarkerArray:
    """2-sigma ellipse (CYLINDER) and id label per landmark, DELETE for each removed key.

    Markers are keyed by the landmark's stable key, so an update replaces the previous marker
    of the same landmark and a removed landmark disappears from RViz.
    """
    markers = []
    if len(landmark_map.means):
        major, minor, angles = ellipse_axes(landmark_map.covariances)
    for index, key in enumerate(landmark_map.keys):
        key = int(key)
        x, y = float(landmark_map.means[index, 0]), float(landmark_map.means[index, 1])
        existence = float(landmark_map.existence[index])
        ellipse = Marker(header=header, ns=ELLIPSE_NAMESPACE, id=key, type=Marker.CYLINDER,
                         action=Marker.ADD, pose=pose_msg((x, y, float(angles[index]))),
                         color=ColorRGBA(r=0.1, g=0.4, b=1.0, a=0.25 + 0.6 * existence))
        ellipse.scale.x, ellipse.scale.y = float(major[index]), float(minor[index])
        ellipse.scale.z = ELLIPSE_HEIGHT
        landmark_id = int(landmark_map.ids[index])
        label = Marker(header=header, ns=LABEL_NAMESPACE, id=key, type=Marker.TEXT_VIEW_FACING,
                       action=Marker.ADD, text=str(landmark_id) if landmark_id >= 0 else f"k{key}",
                       color=ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0))
        label.pose.position = Point(x=x, y=y, z=LABEL_LIFT)
        label.pose.orientation.w = 1.0
        label.scale.z = LABEL_HEIGHT
        markers += [ellipse, label]
    for key in removed_keys:
        markers += [Marker(header=header, ns=namespace, id=int(key), action=Marker.DELETE)
                    for namespace in (ELLIPSE_NAMESPACE, LABEL_NAMESPACE)]
    return MarkerArray(markers=markers)


# --- map file ----------------------------------------------------------------------------------

def write_map_file(file_path: str | Path, landmark_map: LandmarkMapLike, frame_id: str,
                   stamp: float) -> Path:
    """Write the map as CSV (``.csv``) or YAML (any other suffix); return the path written.

    One row per landmark with the columns of ``MAP_FILE_COLUMNS``: stable key, external id
    (-1 unknown), mean (m), covariance entries (m^2) and existence probability.
    """
    file_path = Path(file_path).expanduser()
    file_path.parent.mkdir(parents=True, exist_ok=True)
    rows = [(int(key), int(landmark_id), *map(float, mean), float(cov[0, 0]), float(cov[0, 1]),
             float(cov[1, 1]), float(existence))
            for key, landmark_id, mean, cov, existence in zip(
                landmark_map.keys, landmark_map.ids, landmark_map.means,
                landmark_map.covariances, landmark_map.existence)]
    if file_path.suffix.lower() == ".csv":
        with file_path.open("w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(MAP_FILE_COLUMNS)
            writer.writerows(rows)
    else:
        lines = ["# fastslam_ros landmark map of the best particle",
                 f"frame_id: {json.dumps(frame_id)}", f"stamp: {stamp:.9f}", f"count: {len(rows)}",
                 "landmarks:" if rows else "landmarks: []"]
        lines += ["  - {" + ", ".join(f"{name}: {_yaml_scalar(value)}" for name, value in
                                      zip(MAP_FILE_COLUMNS, row)) + "}" for row in rows]
        file_path.write_text("\n".join(lines) + "\n")
    return file_path


def _yaml_scalar(value: int | float) -> str:
    """A number as YAML 1.1 and 1.2 both read it back (``1e-05`` is a string to YAML 1.1)."""
    if isinstance(value, int):
        return str(value)
    if not math.isfinite(value):
        return ".nan" if math.isnan(value) else (".inf" if value > 0 else "-.inf")
    text = repr(value)
    if "e" in text and "." not in text:
        mantissa, exponent = text.split("e")
        text = f"{mantissa}.0e{exponent}"
    return text
