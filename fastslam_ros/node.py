"""ROS 2 node around the FastSLAM core: time alignment of odometry and landmark clouds, outputs.

The node does no estimation math. It reads odometry and landmark clouds, feeds the filter in
stamp order (the particles are predicted to each observation's stamp with odometry interpolated
there), and publishes the estimate. Every publish goes through ``_publish``, which also hands the
message to ``output_listeners``; throttled outputs follow the node clock inside the callbacks,
so a replay that calls the callbacks directly and sets the clock gets the same outputs as a live
run. See docs/node.md for the interface and the parameters.
"""
from __future__ import annotations

import argparse
import bisect
import math
import re
import sys
import time
from dataclasses import dataclass
from os import PathLike
from typing import Callable

import numpy as np
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Odometry, Path
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)
from rclpy.exceptions import InvalidParameterValueException, ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_dict_from_yaml_file
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy)
from rclpy.utilities import remove_ros_args
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from fastslam_ros import ros_io
from fastslam_ros.core import FastSLAM, FastSLAMConfig
from fastslam_ros.core.params import (ParameterValueError, Spec, check_fields, parameter,
                                      specs)
from fastslam_ros.core.geometry import compose, relative_pose, wrap_scalar
from fastslam_ros.core.observation import MIN_OBSERVATION_RANGE
from fastslam_ros.core.timing import InputRate, OdometryHistory, Throttle

try:  # Only a full ROS install has tf2_ros; ~/map_to_odom carries the same transform anyway.
    from tf2_ros import TransformBroadcaster
except ImportError:
    TransformBroadcaster = None

NODE_NAME = "fastslam"
TIME_JUMP_BACK = 1.0
"""An input stamp this much (s) older than the newest one means time went backwards (a looped
bag, a restarted simulation): the filter resets, once confirmed. Smaller steps back are
out-of-order messages."""
TIME_JUMP_FORWARD = 10.0
"""An input stamp this much (s) newer than the newest one is a jump forward (or a stray stamp)."""
STAMP_CONFIRMATIONS = 3
"""A time jump is accepted only when this many consecutive messages agree on the new time; the
messages before that are dropped as outlier stamps, so one stray stamp is never used and never
resets the filter."""
ODOMETRY_CONFIRMATIONS = 5
"""An odometry jump beyond max_speed / max_yaw_rate is accepted (the odometry restarted
elsewhere; the filter carries on from where it was) only when this many consecutive messages
continue it plausibly; before that each one is dropped as implausible."""
ODOMETRY_SLACK = (0.1, 0.1)
"""m and rad allowed on top of max_speed and max_yaw_rate times the step (stamp jitter)."""
MAX_ODOMETRY_COORDINATE = 1e7
"""m: an odometry position farther out is dropped (overflows the motion model's squares)."""
LAG_WARNING = 1.0
"""s: a reading processed this long after its stamp (node time) makes the diagnostics WARN."""
DIAGNOSTICS_PERIOD = 1.0
"""Seconds of node time between two /diagnostics messages."""

INPUT_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=50,
                       reliability=ReliabilityPolicy.BEST_EFFORT,
                       durability=DurabilityPolicy.VOLATILE)
"""REP 2003 sensor-data inputs; a best-effort reader also connects to reliable writers (bags)."""
MAP_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""REP 2003 map outputs: a late subscriber (RViz opened later) still receives the last map."""
LATEST_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
STREAM_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)

COUNTERS = (
    "received_odom", "received_landmarks",          # messages in
    "used_odom", "used_landmarks",                  # messages the filter used
    "observations_used",                            # cloud points given to the filter
    "late_observations",      # clouds older than the filter's time: used at the filter's pose
    "stale_observations",     # clouds that waited max_observation_wait: used at the latest odometry
    "resets", "time_jumps",                         # filter resets (service or time going back)
    "initial_poses",                                # poses given on initialpose
    "associations_checked", "associations_correct",  # clouds with ids, association != known
    "odometry_jumps",         # confirmed odometry discontinuities, bridged with zero motion
    "filter_recoveries",      # updates after which the filter repaired a non-finite state
    "odom_missing", "landmarks_missing",  # messages estimated lost from gaps in the stamps
    # points dropped from a cloud:
    "dropped_nan", "dropped_too_close", "dropped_out_of_range", "dropped_missing_id",
    # whole messages dropped:
    "dropped_malformed_cloud", "dropped_oversized_cloud", "dropped_wrong_frame",
    "dropped_invalid_quaternion", "dropped_implausible_odometry", "dropped_invalid_stamp",
    "dropped_outlier_stamp", "dropped_duplicate_stamp", "dropped_time_backwards",
    "dropped_stale", "dropped_internal_error",
)

POSE_ESTIMATES = ("best", "mean")
REQUIRED_STRINGS = ("odom_frame", "map_frame", "base_frame", "save_map_file")
THROTTLED_OUTPUTS = ("particles_rate", "markers_rate", "path_rate")
INT64_LIMITS = (-2**63, 2**63 - 1)
GRAPH_PARAMETER_PREFIXES = ("qos_overrides.",)
"""Parameters rclpy declares itself when asked (QoS overrides): never reported as unknown."""


@dataclass(frozen=True)
class NodeSettings:
    """The ROS side of the node: frames, output rates and files (may change at runtime)."""

    odom_frame: str = parameter(
        "odom", "Odometry frame (REP 105): odometry must be stamped in it ('' accepted). "
        "Not empty.")
    map_frame: str = parameter(
        "map", "Frame of ~/pose, ~/path, ~/particles, ~/landmarks and ~/map_cloud. Not empty.")
    base_frame: str = parameter(
        "base_link", "Robot frame (REP 105): odometry must have it as child_frame_id ('' "
        "accepted). Not empty.")
    sensor_frame: str = parameter(
        "", "Frame the landmark clouds must be in; '' accepts any frame.")
    pose_estimate: str = parameter(
        "best", "~/pose is the reported particle's pose (best) or the weighted mean (mean).",
        choices=POSE_ESTIMATES)
    particles_rate: float = parameter(
        2.0, "Maximum rate of ~/particles (Hz of node time; 0: never).", low=0.0, high=1000.0)
    markers_rate: float = parameter(
        1.0, "Maximum rate of ~/landmarks and ~/map_cloud (Hz; 0: never).", low=0.0,
        high=1000.0)
    path_rate: float = parameter(
        1.0, "Maximum rate of ~/path (Hz of node time; 0: never).", low=0.0, high=1000.0)
    max_observation_wait: float = parameter(
        0.5, "How long (s of node time) a cloud waits for odometry that covers its stamp; also "
        "how late (s of stamps) a cloud may arrive and still get its exact interpolated pose.",
        low=0.0, high=60.0)
    map_file: str = parameter(
        "", "Landmark map (the YAML or CSV that ~/save_map writes) read at start and by "
        "~/load_map; it seeds every particle's map. '' starts with an empty map (needed with "
        "mode localization).")
    save_map_file: str = parameter(
        "fastslam_map.yaml", "File written by ~/save_map: .csv is CSV, anything else YAML. "
        "Not empty.")
    publish_tf: bool = parameter(
        True, "Broadcast map -> odom on /tf (when tf2_ros is installed).")
    max_speed: float = parameter(
        20.0, "Odometry plausibility gate (m/s): a step between consecutive odometry poses "
        "faster than this is a glitch and dropped, unless the next messages confirm it.",
        low=1e-3, high=1e5)
    max_yaw_rate: float = parameter(
        10.0, "Odometry plausibility gate on the heading (rad/s), as max_speed.", low=1e-3,
        high=1e4)
    max_observations_per_cloud: int = parameter(
        200, "A landmark cloud with more points is dropped whole, unread, so one message's cost "
        "is bounded (thinning it would give negative evidence to landmarks it did see).",
        low=1, high=1_000_000)
    path_max_poses: int = parameter(
        1000, "~/path holds at most this many poses: a longer path is decimated evenly (always "
        "ending at the newest pose), so its cost stays flat over any run length.",
        low=3, high=10_000_000)

    def validate(self) -> "NodeSettings":
        """Raise ``ParameterValueError`` naming the bad setting; return self when all are good."""
        check_fields(self)
        for name in REQUIRED_STRINGS:
            if not getattr(self, name):
                raise ParameterValueError(name, "must not be empty")
        return self


CORE_PARAMETERS = specs(FastSLAMConfig)
"""{name: (default, spec)} of the filter's parameters, fixed at start."""
NODE_PARAMETERS = specs(NodeSettings)
"""{name: (default, spec)} of the ROS-side parameters, which may change at runtime."""


class ParameterError(ValueError):
    """A parameter value that stops the node from starting; the message names the parameter."""


@dataclass
class Observation:
    """A landmark cloud ready for the filter: range (m) and bearing (rad) in the sensor frame."""

    stamp: float
    ranges: np.ndarray
    bearings: np.ndarray
    ids: np.ndarray | None
    arrival: float
    """Node-clock time (s) at which the cloud arrived, for the max_observation_wait bound."""


def parameter_descriptor(default: object, spec: Spec, note: str = "") -> ParameterDescriptor:
    """The ROS descriptor of a parameter from its spec: the description (with the choices of a
    string, the exact rule of a number) and, for numbers, the inclusive range."""
    description = spec.description
    if spec.choices is not None:
        description += f" One of: {' | '.join(spec.choices)}."
    descriptor = ParameterDescriptor(description=description + note)
    if isinstance(default, bool) or not isinstance(default, (int, float)):
        return descriptor
    descriptor.description = f"{description} Valid: {spec.rule()}.{note}"
    if isinstance(default, int):
        low = INT64_LIMITS[0] if spec.low is None else int(spec.low)
        high = INT64_LIMITS[1] if spec.high is None else int(spec.high)
        descriptor.integer_range = [IntegerRange(from_value=low, to_value=high, step=0)]
    else:
        low = -math.inf if spec.low is None else float(spec.low)
        high = math.inf if spec.high is None else float(spec.high)
        descriptor.floating_point_range = [FloatingPointRange(from_value=low, to_value=high,
                                                              step=0.0)]
    return descriptor


def parameter_error(error: ParameterValueError) -> "ParameterError":
    """A ParameterError that names the parameter(s) as the user typed them."""
    quoted = ", ".join(f"'{name}'" for name in error.names)
    return ParameterError(f"parameter{'s' if len(error.names) > 1 else ''} {quoted}: "
                          f"{error.reason}")


class _NothingToDestroy:
    """Stands in for a part that a failed ``Node.__init__`` never made."""

    def destroy(self) -> None:
        pass


def decimation(length: int, limit: int) -> np.ndarray | None:
    """Indices of at most ``limit`` of ``length`` items, evenly spread and ending at the last;
    None when all fit. The stride is a power of two, so the kept items stay the same from one
    call to the next while the sequence grows (their messages are reused)."""
    if length <= limit:
        return None
    stride = 1 << math.ceil(math.log2((length - 1) / max(limit - 2, 1)))
    indices = np.arange(0, length, stride)
    return indices if indices[-1] == length - 1 else np.append(indices, length - 1)


class FastSLAMNode(Node):
    """Landmark FastSLAM on ``odom`` + ``landmarks``; publishes pose, map, path and particles."""

    def __init__(self, **node_kwargs) -> None:
        """Declare parameters (ParameterError on a bad value), create the filter and the I/O.

        A failed start destroys the half-built node at once: left to the garbage collector, its
        DDS participant would be torn down at some later, arbitrary point (Fast DDS can then
        block the whole process)."""
        try:
            super().__init__(NODE_NAME, **node_kwargs)
        except ParameterException as error:  # e.g. use_sim_time given as a string
            if getattr(self, "_Node__node", None) is not None:
                # Node.__init__ stopped before it made its type description service.
                if not hasattr(self, "_type_description_service"):
                    self._type_description_service = _NothingToDestroy()
                Node.destroy_node(self)
            raise ParameterError(f"{error}") from None
        try:
            self._set_up()
        except BaseException:
            Node.destroy_node(self)  # not the override: its counters may not exist yet
            raise

    def _set_up(self) -> None:
        """Everything of the start after the rcl node exists."""
        self.output_listeners: list[Callable[[str, object], None]] = []
        self.publish_to_dds = True
        """False: outputs go only to ``output_listeners`` (an in-process replay, no DDS cost)."""
        self.stats: dict[str, int] = dict.fromkeys(COUNTERS, 0)
        self.settings: dict[str, object] = {}
        """Current values of the ROS-side parameters (runtime changes land here)."""
        self._throttles: dict[str, Throttle] = {}
        self.config = self._declare_core_parameters()
        self._declare_ros_parameters()
        self._check_unknown_parameters()
        self.add_on_set_parameters_callback(self._check_parameter_change)
        self.add_post_set_parameters_callback(self._apply_parameter_change)

        started = time.perf_counter()
        self.slam = FastSLAM(self.config)
        """The filter (random generator seeded from the ``seed`` parameter); read it, the node
        feeds it. Built before the subscriptions: the compiled backend is ready (compiled or
        loaded from its cache) before the first message."""
        self._initial_pose: tuple[np.ndarray, np.ndarray] | None = None
        """A pose given on ``initialpose`` before the first odometry, applied with it."""
        self.get_logger().info(f"core backend {self.slam.backend} ready in "
                               f"{time.perf_counter() - started:.1f} s")
        self._odometry = OdometryHistory()
        self._odometry_correction = np.zeros(3)
        """Pose of the raw odometry frame in the odometry frame the filter follows: it bridges
        confirmed odometry jumps with zero motion (identity until the first one)."""
        self._odometry_candidates: list[tuple[float, np.ndarray]] = []
        self._stamp_candidates: list[float] = []
        self._rates = {"odom": InputRate(), "landmarks": InputRate()}
        self._worst_lag = 0.0
        self._worst_callback = 0.0
        self._warned_at_last_diagnostics: dict[str, int] = {}
        self._pending: list[Observation] = []
        self._newest_stamp: float | None = None
        self._last_cloud_stamp: float | None = None
        self._last_update_stamp = 0.0
        self._map_dirty = False
        self._published_keys: set[int] = set()
        self._path_builder = ros_io.PathBuilder()
        self._marker_builder = ros_io.MarkerBuilder()
        self._diagnostics_throttle = Throttle(1.0 / DIAGNOSTICS_PERIOD)

        self._pose_pub = self.create_publisher(PoseWithCovarianceStamped, "~/pose", STREAM_QOS)
        self._path_pub = self.create_publisher(Path, "~/path", LATEST_QOS)
        self._markers_pub = self.create_publisher(MarkerArray, "~/landmarks", MAP_QOS)
        self._map_cloud_pub = self.create_publisher(PointCloud2, "~/map_cloud", MAP_QOS)
        self._particles_pub = self.create_publisher(PoseArray, "~/particles", LATEST_QOS)
        self._map_to_odom_pub = self.create_publisher(TransformStamped, "~/map_to_odom", STREAM_QOS)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", STREAM_QOS)
        self._tf_broadcaster = TransformBroadcaster(self) if TransformBroadcaster else None
        self.create_subscription(Odometry, "odom", self.on_odometry, INPUT_QOS)
        self.create_subscription(PointCloud2, "landmarks", self.on_landmarks, INPUT_QOS)
        self.create_subscription(PoseWithCovarianceStamped, "initialpose", self.on_initial_pose,
                                 LATEST_QOS)
        self.create_service(Trigger, "~/reset", self._on_reset)
        self.create_service(Trigger, "~/save_map", self._on_save_map)
        self.create_service(Trigger, "~/load_map", self._on_load_map)
        self.create_timer(DIAGNOSTICS_PERIOD, self._on_timer)
        if self.settings["map_file"]:
            try:
                self._load_map(self.settings["map_file"])
                self._publish_map()  # latched: RViz shows the loaded map at once
            except ros_io.MapFileError as error:
                raise ParameterError(f"parameter 'map_file': {error}") from None
        elif self.config.mode == "localization":
            raise ParameterError("parameters 'mode', 'map_file': mode localization needs a "
                                 "map_file to localize on")
        self.get_logger().info(
            f"FastSLAM {self.config.algorithm}, {self.config.num_particles} particles, "
            f"association {self.config.association}; map frame '{self.settings['map_frame']}'")

    # --- parameters ----------------------------------------------------------------------------

    def _declare(self, name: str, default: object, spec: Spec, note: str = "") -> object:
        """Declare one parameter from its spec; a value of the wrong type or outside the
        descriptor's range raises ParameterError."""
        try:
            return self.declare_parameter(name, default,
                                          parameter_descriptor(default, spec, note)).value
        except InvalidParameterValueException:  # outside the descriptor's range
            given = self._parameter_overrides[name].value
            raise ParameterError(f"parameter '{name}': must be {spec.rule()} "
                                 f"(got {given!r})") from None
        except ParameterException as error:
            raise ParameterError(f"parameter '{name}': {error}") from None

    def _declare_core_parameters(self) -> FastSLAMConfig:
        """One parameter per FastSLAMConfig field; the validated config built from them."""
        values = {name: self._declare(name, default, spec, " Fixed at start (restart to change).")
                  for name, (default, spec) in CORE_PARAMETERS.items()}
        try:
            return FastSLAMConfig(**values).validate()
        except ParameterValueError as error:
            raise parameter_error(error) from None

    def _declare_ros_parameters(self) -> None:
        """Frames, rates and the rest of the ROS side, cached in ``self.settings``."""
        values = {name: self._declare(name, default, spec)
                  for name, (default, spec) in NODE_PARAMETERS.items()}
        try:
            NodeSettings(**values).validate()
        except ParameterValueError as error:
            raise parameter_error(error) from None
        self._apply_parameter_change([self.get_parameter(name) for name in NODE_PARAMETERS])

    def _check_unknown_parameters(self) -> None:
        """Fail on a parameter given (command line, file) that the node does not declare, e.g.
        a misspelled name, which would otherwise be ignored silently."""
        unknown = sorted(name for name in self._parameter_overrides
                         if not self.has_parameter(name)
                         and not name.startswith(GRAPH_PARAMETER_PREFIXES))
        if unknown:
            raise ParameterError(f"unknown parameter{'s' if len(unknown) > 1 else ''} "
                                 f"{', '.join(repr(name) for name in unknown)} (not declared "
                                 f"by {self.get_name()}; misspelled?)")

    def _check_parameter_change(self, parameters: list[Parameter]) -> SetParametersResult:
        """Accept runtime changes of ROS-side parameters; core ones need a restart."""
        changes = {}
        for changed in parameters:
            if changed.name in CORE_PARAMETERS:
                return SetParametersResult(successful=False, reason=(
                    f"{changed.name}: core parameters are fixed while the filter runs; restart "
                    "the node with the new value"))
            if changed.name in NODE_PARAMETERS:
                changes[changed.name] = changed.value
        current = {name: self.settings.get(name, default)
                   for name, (default, _) in NODE_PARAMETERS.items()}
        try:
            NodeSettings(**{**current, **changes}).validate()
        except ParameterValueError as error:
            return SetParametersResult(successful=False, reason=str(parameter_error(error)))
        return SetParametersResult(successful=True)

    def _apply_parameter_change(self, parameters: list[Parameter]) -> None:
        """Cache the ROS-side values the callbacks read; a new rate restarts its throttle."""
        for changed in parameters:
            if changed.name in NODE_PARAMETERS:
                self.settings[changed.name] = changed.value
            if changed.name in THROTTLED_OUTPUTS:
                self._throttles[changed.name] = Throttle(changed.value)

    # --- inputs --------------------------------------------------------------------------------

    def on_odometry(self, msg: Odometry) -> None:
        """Subscription callback: store the odometry pose, then run what it makes ready."""
        self.stats["received_odom"] += 1
        start = time.perf_counter()
        try:
            self._handle_odometry(msg)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"odometry callback failed: {error!r}")
        self._worst_callback = max(self._worst_callback, time.perf_counter() - start)

    def on_landmarks(self, msg: PointCloud2) -> None:
        """Subscription callback: convert the cloud to range/bearing and queue it by stamp."""
        self.stats["received_landmarks"] += 1
        start = time.perf_counter()
        try:
            self._handle_landmarks(msg)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"landmarks callback failed: {error!r}")
        self._worst_callback = max(self._worst_callback, time.perf_counter() - start)

    def on_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        """Subscription callback (RViz "2D Pose Estimate"): redraw the particles around the
        given map-frame pose with its covariance."""
        try:
            self._handle_initial_pose(msg)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"initialpose callback failed: {error!r}")

    def _handle_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        if not self._frame_ok("map_frame", msg.header.frame_id, "initialpose"):
            return
        try:
            pose = ros_io.odometry_pose(msg)
        except ros_io.InvalidQuaternionError as error:
            return self._drop("invalid_quaternion", f"initialpose dropped: {error}")
        except ros_io.NonFiniteError as error:
            return self._drop("nan", f"initialpose dropped: {error}")
        covariance = ros_io.planar_covariance(msg.pose.covariance)
        if covariance is None:
            return self._drop("nan", "initialpose dropped: covariance not finite and "
                                     "positive semi-definite in x, y, yaw")
        self.stats["initial_poses"] += 1
        self.get_logger().info(f"initial pose ({pose[0]:.2f}, {pose[1]:.2f}, {pose[2]:.2f}): "
                               "particles redrawn around it")
        if self._odometry.latest_stamp is None:
            self._initial_pose = (pose, covariance)  # the first odometry would reset it
        else:
            self._process_ready(self._now(), force=True)
            self.slam.initialize_pose(pose, covariance)
        self._publish_particles()

    def _handle_odometry(self, msg: Odometry) -> None:
        if not (self._frame_ok("odom_frame", msg.header.frame_id, "odometry")
                and self._frame_ok("base_frame", msg.child_frame_id, "odometry child")):
            return
        try:
            pose = ros_io.odometry_pose(msg)
        except ros_io.InvalidQuaternionError as error:
            return self._drop("invalid_quaternion", f"odometry dropped: {error}")
        except ros_io.NonFiniteError as error:
            return self._drop("nan", f"odometry dropped: {error}")
        if not np.all(np.abs(pose[:2]) <= MAX_ODOMETRY_COORDINATE):
            return self._drop("implausible_odometry", f"odometry position {pose[:2]} is beyond "
                                                      f"{MAX_ODOMETRY_COORDINATE:g} m")
        stamp = self._stamp(msg.header.stamp, "odometry")
        if stamp is None:
            return
        latest = self._odometry.latest_stamp
        if latest is not None and stamp == latest:
            return self._drop("duplicate_stamp", f"odometry with a repeated stamp {stamp:.9f}")
        if latest is not None and stamp < latest:
            return self._drop("time_backwards", f"odometry stamp {stamp:.9f} is older than the "
                                                f"previous one ({latest:.9f})")
        pose = compose(self._odometry_correction, pose)
        if latest is not None and not self._odometry_plausible(stamp, pose):
            return
        if latest is None:
            self.slam.reset(initial_pose=tuple(pose))  # map frame starts at the first odometry
            if self._initial_pose is not None:
                self.slam.initialize_pose(*self._initial_pose)
        self._odometry.append(stamp, pose)
        self.stats["odom_missing"] += self._rates["odom"].record(stamp, self._now())
        self.stats["used_odom"] += 1
        now = self._now()
        self._process_ready(now)
        self._advance_idle()
        self._publish_throttled(now)

    def _handle_landmarks(self, msg: PointCloud2) -> None:
        if not self._frame_ok("sensor_frame", msg.header.frame_id, "landmark cloud"):
            return
        size, cap = ros_io.cloud_size(msg), self.settings["max_observations_per_cloud"]
        if size > cap:
            return self._drop("oversized_cloud", f"landmark cloud of {size} points dropped "
                                                 f"(max_observations_per_cloud {cap})")
        try:
            cloud = ros_io.read_landmark_cloud(msg)
        except ros_io.MalformedCloudError as error:
            return self._drop("malformed_cloud", f"landmark cloud dropped: {error}")
        stamp = self._stamp(msg.header.stamp, "landmark cloud")
        if stamp is None:
            return
        self.stats["landmarks_missing"] += self._rates["landmarks"].record(stamp, self._now())
        if stamp == self._last_cloud_stamp or any(o.stamp == stamp for o in self._pending):
            return self._drop("duplicate_stamp",
                              f"landmark cloud with a repeated stamp {stamp:.9f}")
        now = self._now()
        observation = self._observation(cloud, stamp, now)
        if observation is not None:
            bisect.insort(self._pending, observation, key=lambda o: o.stamp)
        self._process_ready(now)
        self._publish_throttled(now)

    def _observation(self, cloud: ros_io.LandmarkCloud, stamp: float,
                     arrival: float) -> Observation | None:
        """Range/bearing of the valid points; None when the cloud had points and none is valid.

        Such a cloud is not used: an empty update would lower the existence of the very
        landmarks that were seen. An empty cloud is valid (nothing seen).
        """
        finite = np.isfinite(cloud.x) & np.isfinite(cloud.y)
        ranges = np.hypot(cloud.x, cloud.y)
        far_enough = ~finite | (ranges >= MIN_OBSERVATION_RANGE)
        in_range = ~finite | (ranges <= self.config.max_range)
        keep = finite & far_enough & in_range
        self._count_points("nan", finite, "non-finite x/y")
        self._count_points("too_close", far_enough, f"range below {MIN_OBSERVATION_RANGE} m "
                                                    "(at the sensor origin, or byte-swapped data)")
        self._count_points("out_of_range", in_range, f"range beyond max_range "
                                                     f"({self.config.max_range} m)")
        ids = cloud.ids
        if self.config.association == "known":
            labelled = (np.zeros_like(keep) if ids is None else ids >= 0) | ~keep
            self._count_points("missing_id", labelled,
                               "no id (-1 or no 'id' field) with association 'known'")
            keep &= labelled
        if keep.size and not keep.any():
            return None
        return Observation(stamp=stamp, ranges=ranges[keep],
                           bearings=np.arctan2(cloud.y[keep], cloud.x[keep]),
                           ids=None if ids is None else ids[keep], arrival=arrival)

    def _frame_ok(self, parameter: str, frame_id: str, what: str) -> bool:
        """Whether a frame id matches its parameter (an empty id or parameter matches all);
        counts and warns when not."""
        frame, expected = frame_id.lstrip("/"), self.settings[parameter]
        if not frame or not expected or frame == expected:
            return True
        self._drop("wrong_frame", f"{what} frame '{frame}' is not '{expected}' "
                                  f"(parameter {parameter})")
        return False

    def _count_points(self, reason: str, valid: np.ndarray, what: str) -> None:
        dropped = int(np.count_nonzero(~valid))
        if dropped:
            self._drop(reason, f"{dropped} landmark point(s) dropped: {what}", dropped)

    def _drop(self, reason: str, message: str, count: int = 1) -> None:
        """Count dropped input by reason and warn (throttled)."""
        self.stats[f"dropped_{reason}"] += count
        self.get_logger().warning(f"{message} [dropped_{reason}]", throttle_duration_sec=5.0)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _stamp(self, stamp_msg, what: str) -> float | None:
        """Seconds of a message's stamp, or None (counted) for an invalid or an outlier stamp."""
        try:
            stamp = ros_io.checked_stamp_to_seconds(stamp_msg)
        except ros_io.InvalidStampError as error:
            self._drop("invalid_stamp", f"{what} dropped: {error}")
            return None
        return stamp if self._stamp_usable(stamp, what) else None

    def _stamp_usable(self, stamp: float, what: str) -> bool:
        """Whether a stamp fits the input's time; a jump is used only once confirmed.

        A stamp more than TIME_JUMP_BACK s before or TIME_JUMP_FORWARD s after the newest one
        is an outlier and dropped, until STAMP_CONFIRMATIONS consecutive messages agree on the
        new time: then time went backwards (looped bag: buffered clouds go in, the filter
        resets) or jumped forward (a pause), and the run goes on from there.
        """
        newest = self._newest_stamp
        if newest is None or newest - TIME_JUMP_BACK <= stamp <= newest + TIME_JUMP_FORWARD:
            self._stamp_candidates.clear()
            self._newest_stamp = stamp if newest is None else max(newest, stamp)
            return True
        candidates = self._stamp_candidates
        if candidates and not (candidates[-1] - TIME_JUMP_BACK <= stamp
                               <= candidates[-1] + TIME_JUMP_FORWARD):
            candidates.clear()
        candidates.append(stamp)
        if len(candidates) < STAMP_CONFIRMATIONS:
            self._drop("outlier_stamp", f"{what} stamped {stamp:.3f} s, {stamp - newest:+.3f} s "
                                        f"from the newest input ({newest:.3f} s): dropped until "
                                        f"{STAMP_CONFIRMATIONS} messages in a row agree")
            return False
        candidates.clear()
        self.stats["time_jumps"] += 1
        self._rates = {topic: InputRate() for topic in self._rates}  # the gap is no loss
        if stamp < newest:
            self.get_logger().warning(
                f"time went backwards from {newest:.3f} s to {stamp:.3f} s (looped bag?): "
                "resetting the filter", throttle_duration_sec=5.0)
            self._process_ready(self._now(), force=True)
            self.reset()
        else:
            self.get_logger().warning(f"time jumped forward from {newest:.3f} s to {stamp:.3f} s",
                                      throttle_duration_sec=5.0)
        self._newest_stamp = stamp
        return True

    def _odometry_plausible(self, stamp: float, pose: np.ndarray) -> bool:
        """The max_speed / max_yaw_rate gate between the newest odometry and this pose.

        A jump is dropped (counted) unless ODOMETRY_CONFIRMATIONS consecutive messages continue
        it plausibly: the odometry then restarted elsewhere, and the frame the filter follows is
        shifted so that the jump is no motion at all.
        """
        if self._step_plausible(self._odometry.latest_stamp, self._odometry.latest_pose,
                                stamp, pose):
            self._odometry_candidates.clear()
            return True
        candidates = self._odometry_candidates
        if candidates and not self._step_plausible(*candidates[-1], stamp, pose):
            candidates.clear()
        candidates.append((stamp, pose))
        if len(candidates) < ODOMETRY_CONFIRMATIONS:
            latest = self._odometry.latest_pose
            self._drop("implausible_odometry",
                       f"odometry jumps {math.hypot(*(pose[:2] - latest[:2])):.3g} m, "
                       f"{abs(wrap_scalar(pose[2] - latest[2])):.3g} rad in "
                       f"{stamp - self._odometry.latest_stamp:.3g} s (max_speed "
                       f"{self.settings['max_speed']} m/s, max_yaw_rate "
                       f"{self.settings['max_yaw_rate']} rad/s)")
            return False
        candidates.clear()
        # New frame: the jump itself becomes no motion (latest = shift * pose).
        shift = compose(self._odometry.latest_pose, relative_pose(pose, np.zeros(3)))
        self._odometry_correction = compose(shift, self._odometry_correction)
        pose[:] = self._odometry.latest_pose
        self.stats["odometry_jumps"] += 1
        self.get_logger().warning("odometry jumped and the jump is confirmed: continuing from "
                                  "the current estimate", throttle_duration_sec=5.0)
        return True

    def _step_plausible(self, stamp0: float, pose0: np.ndarray, stamp1: float,
                        pose1: np.ndarray) -> bool:
        step = stamp1 - stamp0
        return bool(
            math.hypot(pose1[0] - pose0[0], pose1[1] - pose0[1])
            <= self.settings["max_speed"] * step + ODOMETRY_SLACK[0]
            and abs(wrap_scalar(pose1[2] - pose0[2]))
            <= self.settings["max_yaw_rate"] * step + ODOMETRY_SLACK[1])

    # --- filter --------------------------------------------------------------------------------

    def _process_ready(self, now: float, force: bool = False) -> None:
        """Run the filter on queued clouds, oldest first, whose odometry has arrived.

        A cloud that waited longer than max_observation_wait (or any cloud, with ``force``) runs
        at the newest odometry; without any odometry it is dropped as stale.
        """
        while self._pending:
            observation = self._pending[0]
            waited = now - observation.arrival
            waited_enough = force or waited > self.settings["max_observation_wait"]
            if not self._odometry.covers(observation.stamp):
                if not waited_enough:
                    return
                if self._odometry.latest_stamp is None:
                    self._pending.pop(0)
                    self._drop("stale", "landmark cloud dropped: no odometry has arrived")
                    continue
                self.stats["stale_observations"] += 1
            self._pending.pop(0)
            self._update(observation)

    def _advance_idle(self) -> None:
        """Predict through odometry older than max_observation_wait, so the history stays short
        and a robot that sees nothing still moves in small steps."""
        latest = self._odometry.latest_stamp
        if latest is not None:
            horizon = latest - self.settings["max_observation_wait"]
            for pose_from, pose_to in self._odometry.advance(horizon):
                self.slam.predict(pose_from, pose_to)

    def _update(self, observation: Observation) -> None:
        """Predict to the observation's stamp, update, publish the per-observation outputs."""
        if observation.stamp < self._odometry.anchor_stamp:
            self.stats["late_observations"] += 1
        for pose_from, pose_to in self._odometry.advance(observation.stamp):
            self.slam.predict(pose_from, pose_to)
        check_ids = observation.ids is not None and self.config.association != "known"
        known_before = set(self.slam.best_map().ids.tolist()) if check_ids else set()
        recoveries = self.slam.num_recoveries
        try:
            report = self.slam.update(observation.ranges, observation.bearings,
                                       ids=observation.ids, stamp=observation.stamp)
        except (ValueError, ArithmeticError) as error:
            if not self.slam.check_state():  # not a broken state: a real bug, reported as such
                raise
            self.stats["filter_recoveries"] += 1
            return self._drop("internal_error", f"update failed on a non-finite filter state "
                                                f"({error!r}): repaired, reading lost")
        if self.slam.num_recoveries != recoveries:
            self.stats["filter_recoveries"] += 1
            self.get_logger().warning(
                "the filter's state was not finite after an update: repaired from the finite "
                "particles (or reset) [filter_recoveries]", throttle_duration_sec=5.0)
        self._worst_lag = max(self._worst_lag, self._now() - observation.stamp)
        if check_ids:
            self._check_associations(observation.ids, report, known_before)
        self.stats["used_landmarks"] += 1
        self.stats["observations_used"] += len(observation.ranges)
        self._last_cloud_stamp = observation.stamp
        self._last_update_stamp = observation.stamp
        self._map_dirty = True
        self._publish_pose()

    def _check_associations(self, ids: np.ndarray, report, known_before: set[int]) -> None:
        """Score data association against the labels carried by the cloud.

        An observation associated to an existing landmark is correct when the landmark carries
        its label; one that started a new landmark is correct when its label was not yet mapped.
        """
        labelled = ids >= 0
        associated = labelled & ~report.is_new & (report.associated_ids >= 0)
        new = labelled & report.is_new
        correct_new = sum(int(label) not in known_before for label in ids[new])
        self.stats["associations_checked"] += int(np.count_nonzero(associated | new))
        self.stats["associations_correct"] += int(
            np.count_nonzero(report.associated_ids[associated] == ids[associated])) + correct_new

    def reset(self) -> None:
        """Forget the map, the trajectory and all buffered input; the next odometry restarts."""
        self.slam.reset()
        self._odometry = OdometryHistory()
        self._odometry_correction = np.zeros(3)
        self._odometry_candidates.clear()
        self._pending.clear()
        self._newest_stamp = None
        self._last_cloud_stamp = None
        self._map_dirty = True
        self.stats["resets"] += 1
        self._publish_map()

    def flush(self) -> None:
        """Run every queued cloud now (end of a bag) and publish all outputs once."""
        now = self._now()
        self._process_ready(now, force=True)
        if self.stats["used_landmarks"]:
            if self._throttles["path_rate"].rate > 0.0:
                self._publish_path()
            if self._throttles["particles_rate"].rate > 0.0:
                self._publish_particles()
        if self._throttles["markers_rate"].rate > 0.0:
            self._publish_map()
        self._publish_diagnostics()

    # --- outputs -------------------------------------------------------------------------------

    def _publish(self, publisher, msg) -> None:
        """Publish and hand the message to every output listener (replay records them)."""
        if self.publish_to_dds:
            publisher.publish(msg)
        for listener in self.output_listeners:
            listener(publisher.topic_name, msg)

    def _header(self) -> Header:
        """Map-frame header at the time of the latest update."""
        return Header(stamp=ros_io.seconds_to_stamp(self._last_update_stamp),
                      frame_id=self.settings["map_frame"])

    def _estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """Pose per ``pose_estimate`` and the covariance of the particle spread."""
        mean, covariance = self.slam.mean_pose_and_covariance()
        best = self.settings["pose_estimate"] == "best"
        return (self.slam.best_pose() if best else mean), covariance

    def _publish_pose(self) -> None:
        """~/pose and map -> odom at the latest observation (every observation: cheap)."""
        header = self._header()
        pose, covariance = self._estimate()
        self._publish(self._pose_pub, ros_io.pose_with_covariance(header, pose, covariance))
        # map -> odom = (map -> base) * (odom -> base)^-1, both at the observation's time (the
        # correction takes the filter's odometry frame back to the raw one).
        map_to_odom = compose(compose(pose, relative_pose(self._odometry.anchor_pose,
                                                          np.zeros(3))),
                              self._odometry_correction)
        transform = ros_io.transform(header, self.settings["odom_frame"], map_to_odom)
        self._publish(self._map_to_odom_pub, transform)
        if self.settings["publish_tf"] and self._tf_broadcaster is not None:
            self._tf_broadcaster.sendTransform(transform)

    def _publish_throttled(self, now: float) -> None:
        """Heavy outputs, each at most at its rate of node time."""
        if self.stats["used_landmarks"]:
            if self._throttles['path_rate'].due(now):
                self._publish_path()
            if self._throttles['particles_rate'].due(now):
                self._publish_particles()
        if self._map_dirty and self._throttles['markers_rate'].due(now):
            self._publish_map()
        if self._diagnostics_throttle.due(now):
            self._publish_diagnostics()

    def _publish_path(self) -> None:
        """~/path: the best particle's path, decimated to at most path_max_poses."""
        stamps, poses = self.slam.best_path()
        keep = decimation(len(stamps), self.settings["path_max_poses"])
        if keep is not None:
            stamps, poses = stamps[keep], poses[keep]
        self._publish(self._path_pub, self._path_builder.build(self._header(), stamps, poses))

    def _publish_particles(self) -> None:
        self._publish(self._particles_pub,
                      ros_io.pose_array(self._header(), self.slam.particle_poses()))

    def _publish_map(self) -> None:
        """~/landmarks markers (DELETE for landmarks gone since the last time) and ~/map_cloud."""
        landmark_map = self.slam.best_map()
        keys = set(landmark_map.keys.tolist())
        header = self._header()
        removed = sorted(self._published_keys - keys)
        self._publish(self._markers_pub, self._marker_builder.build(header, landmark_map, removed))
        self._publish(self._map_cloud_pub, ros_io.map_cloud(header, landmark_map))
        self._published_keys = keys
        self._map_dirty = False

    def _diagnostic_problems(self, now: float) -> list[str]:
        """What went wrong since the last report, worst first: drops, input gaps, silence,
        processing lag, late readings, repairs of the filter."""
        stats, seen = self.stats, self._warned_at_last_diagnostics
        drops = sum(v for k, v in stats.items() if k.startswith("dropped_"))
        counts = {"drops": drops, **{k: stats[k] for k in (
            "odom_missing", "landmarks_missing", "late_observations", "stale_observations",
            "filter_recoveries", "odometry_jumps", "time_jumps")}}
        new = {k: v - seen.get(k, 0) for k, v in counts.items()}
        self._warned_at_last_diagnostics = counts
        problems = []
        if new["drops"]:
            problems.append(f"{new['drops']} input(s) dropped")
        for topic in ("odom", "landmarks"):
            rate = self._rates[topic]
            if new[f"{topic}_missing"] > 0:
                problems.append(f"~{new[f'{topic}_missing']} {topic} message(s) lost (gaps in "
                                f"the stamps up to {rate.largest_gap:.3g} s, usual interval "
                                f"{rate.interval:.3g} s)")
            if silent := rate.silence(now):
                problems.append(f"no {topic} for {silent:.3g} s (usual interval "
                                f"{rate.interval:.3g} s)")
        if self._worst_lag > LAG_WARNING:
            problems.append(f"processing lag {self._worst_lag:.3g} s behind the stamps")
        for key, what in (("late_observations", "clouds older than the filter's time"),
                          ("stale_observations", "clouds used without their odometry"),
                          ("filter_recoveries", "filter state repaired"),
                          ("odometry_jumps", "odometry jumps bridged"),
                          ("time_jumps", "time jumps")):
            if new[key]:
                problems.append(f"{new[key]} {what}")
        return problems

    def _publish_diagnostics(self) -> None:
        """/diagnostics: every counter, the input rates and the processing lag; WARN naming what
        went wrong since the last report (drops, lost messages, silent inputs, lag)."""
        now = self._now()
        problems = self._diagnostic_problems(now)
        rates = [KeyValue(key=f"{topic}_{name}", value=f"{value:.6g}")
                 for topic, rate in self._rates.items()
                 for name, value in (("interval", rate.interval or 0.0),
                                     ("largest_gap", rate.largest_gap),
                                     ("silent_for", rate.silence(now)))]
        timing = [KeyValue(key="processing_lag_max", value=f"{self._worst_lag:.6g}"),
                  KeyValue(key="callback_time_max", value=f"{self._worst_callback:.6g}")]
        self._worst_lag = self._worst_callback = 0.0
        status = DiagnosticStatus(
            level=DiagnosticStatus.WARN if problems else DiagnosticStatus.OK,
            name=f"{self.get_name()}: filter", hardware_id=self.get_fully_qualified_name(),
            message="; ".join(problems) + " since last report" if problems else "running",
            values=[KeyValue(key=k, value=str(v)) for k, v in self.stats.items()]
            + [KeyValue(key="queued_observations", value=str(len(self._pending)))]
            + rates + timing)
        self._publish(self._diagnostics_pub,
                      DiagnosticArray(header=Header(stamp=self.get_clock().now().to_msg()),
                                      status=[status]))

    # --- timer and services --------------------------------------------------------------------

    def _on_timer(self) -> None:
        """Once a second: run clouds that waited too long even if no input arrives any more."""
        try:
            now = self._now()
            self._process_ready(now)
            self._publish_throttled(now)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"timer callback failed: {error!r}")

    def _on_reset(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        try:
            self.reset()
            response.success, response.message = True, "filter reset; waiting for odometry"
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            response.success, response.message = False, f"reset failed: {error!r}"
        return response

    def _on_save_map(self, _request: Trigger.Request,
                     response: Trigger.Response) -> Trigger.Response:
        map_file = self.settings["save_map_file"]
        try:
            landmark_map = self.slam.best_map()
            written = ros_io.write_map_file(map_file, landmark_map, self.settings["map_frame"],
                                            self._last_update_stamp)
            response.success = True
            response.message = f"{len(landmark_map.keys)} landmarks written to {written}"
        except Exception as error:  # noqa: BLE001 - report the failure to the caller
            response.success, response.message = False, f"cannot write '{map_file}': {error}"
        return response

    def _load_map(self, map_file: str) -> int:
        """Seed every particle's map from a map file (ros_io.MapFileError when unreadable);
        returns the number of landmarks."""
        loaded = ros_io.read_map_file(map_file)
        frame = self.settings["map_frame"]
        if loaded.frame_id and loaded.frame_id != frame:
            raise ros_io.MapFileError(f"map file '{map_file}': its frame '{loaded.frame_id}' "
                                      f"is not map_frame '{frame}'")
        self.slam.seed_map(loaded.means, loaded.covariances, loaded.ids)
        self._map_dirty = True
        self.get_logger().info(f"{len(loaded.means)} landmarks loaded from {map_file} "
                               f"({self.config.mode})")
        return len(loaded.means)

    def _on_load_map(self, _request: Trigger.Request,
                     response: Trigger.Response) -> Trigger.Response:
        """Replace every particle's map with ``map_file``'s landmarks (poses kept)."""
        map_file = self.settings["map_file"]
        if not map_file:
            response.success, response.message = False, "parameter map_file is empty"
            return response
        try:
            self._process_ready(self._now(), force=True)
            count = self._load_map(map_file)
            self._publish_map()
            response.success, response.message = True, f"{count} landmarks loaded from {map_file}"
        except Exception as error:  # noqa: BLE001 - report the failure to the caller
            response.success, response.message = False, f"cannot load '{map_file}': {error}"
        return response

    def destroy_node(self) -> None:
        """Destroy, then log the counters (after destruction the log skips /rosout, whose
        publisher is gone when Ctrl-C has already shut the context down)."""
        super().destroy_node()
        counts = ", ".join(f"{key}={value}" for key, value in self.stats.items() if value)
        self.get_logger().info(f"input summary: {counts or 'no input received'}")


def read_params_file(path: str | PathLike, node_name: str = f"/{NODE_NAME}") -> dict[str, object]:
    """{name: value} that a ROS 2 parameter file gives the node ``node_name`` (fully
    qualified), read with rclpy's own parser: the ``/**`` section first, then every section
    whose key matches the node (``fastslam``, ``/robot1/fastslam``, ``/**/fastslam``).

    Raises ParameterError naming the file when it cannot be read or is no parameter file.
    """
    try:
        with open(path, encoding="utf-8") as stream:
            document = yaml.safe_load(stream)
        if not isinstance(document, dict):
            raise RuntimeError("no 'NODE: ros__parameters:' sections")
        sections = [key for key in document
                    if key != "/**" and _section_matches(str(key), node_name)]
        if "/**" not in document and not sections:
            return {}
        messages = parameter_dict_from_yaml_file(str(path), use_wildcard=True,
                                                 target_nodes=sections)
    except OSError as error:
        raise ParameterError(f"parameter file '{path}': {error.strerror or error}") from None
    except (yaml.YAMLError, RuntimeError, AttributeError, TypeError) as error:
        reason = " ".join(str(error).split())
        raise ParameterError(f"parameter file '{path}': not a ROS 2 parameter file "
                             f"({reason})") from None
    values = {name: Parameter.from_parameter_msg(msg).value for name, msg in messages.items()}
    # rclpy re-reads str(value) as YAML 1.1, where the 1e-05 that 1.0e-5 prints as is a string;
    # rcl (the node) reads the file's number as a double, and so does this.
    for key in ["/**", *sections]:
        for name, raw in (document.get(key) or {}).get("ros__parameters", {}).items():
            if isinstance(raw, float) and isinstance(values.get(name), str):
                values[name] = raw
    return values


def _section_matches(key: str, node_name: str) -> bool:
    """Whether a parameter file section key (rcl wildcards ``*`` and ``**``) names the node."""
    pattern = re.escape(key.strip("/")).replace(r"\*\*/", "(.*/)?")
    pattern = pattern.replace(r"\*\*", ".*").replace(r"\*", "[^/]*")
    return re.fullmatch(pattern, node_name.strip("/")) is not None


def _params_files(args: list[str]) -> list[str]:
    """The files given with ``--params-file`` after ``--ros-args``."""
    ros_args = args[args.index("--ros-args") + 1:] if "--ros-args" in args else []
    return [value for flag, value in zip(ros_args, ros_args[1:]) if flag == "--params-file"]


USAGE = """FastSLAM landmark SLAM node: nav_msgs/Odometry on odom and sensor_msgs/PointCloud2 on
landmarks in; pose, path, map markers, map cloud, particles and map -> odom out (docs/node.md).

ROS arguments follow --ros-args, as for every ROS 2 node:
  fastslam_node --ros-args --params-file config/fastslam.yaml -p num_particles:=200 \\
      -r odom:=/wheel/odom -r landmarks:=/detector/landmarks -p use_sim_time:=true
Every parameter, its default and range: docs/parameters.md."""


def parse_command_line(prog: str, usage: str, args: list[str]) -> None:
    """Handle the arguments that are not ROS arguments: ``--help`` prints the usage and exits;
    anything else is a usage error (exit status 2) instead of being ignored."""
    parser = argparse.ArgumentParser(prog=prog, description=usage,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.parse_args(remove_ros_args(args)[1:])


def run_node(prog: str, node_name: str, usage: str, make_node: Callable[[], Node],
             args: list[str] | None = None) -> int:
    """Start, spin and shut down one node as a console command (both nodes' ``main``): a bad
    parameter file, argument or parameter is one line on stderr and exit status 1."""
    argv = sys.argv if args is None else args
    try:
        for path in _params_files(argv):
            read_params_file(path, f"/{node_name}")  # one line instead of rcl's failure
        parse_command_line(prog, usage, argv)
        rclpy.init(args=args)
    except ParameterError as error:
        print(f"{prog}: {error}", file=sys.stderr)
        return 1
    except RuntimeError as error:  # rcl could not parse the arguments
        print(f"{prog}: cannot start: {str(error).splitlines()[0]}", file=sys.stderr)
        return 1
    try:
        node = make_node()
    except ParameterError as error:
        print(f"{prog}: {error}", file=sys.stderr)
        rclpy.try_shutdown()
        return 1
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def main(args: list[str] | None = None) -> int:
    """Console entry point ``fastslam_node``; exit status 1 on a bad parameter or file."""
    return run_node("fastslam_node", NODE_NAME, USAGE, FastSLAMNode, args)


if __name__ == "__main__":
    sys.exit(main())
