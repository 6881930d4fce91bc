"""ROS 2 node around the FastSLAM core: time alignment of odometry and landmark clouds, outputs.

The node does no estimation math. It reads odometry and landmark clouds, feeds the filter in
stamp order (the particles are predicted to each observation's stamp with odometry interpolated
there), and publishes the estimate. Every publish goes through ``_publish``, which also hands the
message to ``output_listeners``; throttled outputs follow the node clock inside the callbacks,
so a replay that calls the callbacks directly and sets the clock gets the same outputs as a live
run. See docs/node.md for the interface and the parameters.
"""
from __future__ import annotations

import ast
import bisect
import dataclasses
import inspect
import math
import sys
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Odometry, Path
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy)
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from fastslam_ros import ros_io
from fastslam_ros.core import FastSLAM, FastSLAMConfig
from fastslam_ros.core import config as config_rules
from fastslam_ros.core.geometry import compose, relative_pose
from fastslam_ros.core.timing import OdometryHistory, Throttle

try:  # Only a full ROS install has tf2_ros; ~/map_to_odom carries the same transform anyway.
    from tf2_ros import TransformBroadcaster
except ImportError:
    TransformBroadcaster = None

NODE_NAME = "fastslam"
TIME_JUMP_BACK = 1.0
"""An input stamp this much (s) older than the newest one means time went backwards (a looped
bag, a restarted simulation): the filter resets. Smaller steps back are out-of-order messages."""
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
    "associations_checked", "associations_correct",  # clouds with ids, association != known
    # points dropped from a cloud:
    "dropped_nan", "dropped_negative_range", "dropped_out_of_range", "dropped_missing_id",
    # whole messages dropped:
    "dropped_malformed_cloud", "dropped_wrong_frame", "dropped_invalid_quaternion",
    "dropped_duplicate_stamp", "dropped_time_backwards", "dropped_stale",
    "dropped_internal_error",
)

POSE_ESTIMATES = ("best", "mean")
REQUIRED_STRINGS = ("odom_frame", "map_frame", "base_frame", "map_file")
THROTTLED_OUTPUTS = ("particles_rate", "markers_rate", "path_rate")
FLOAT_MAX = float("inf")
CORE_RANGES = {
    "num_particles": (1, 1_000_000),
    "seed": (-1, 2**31 - 1),
    "resample_threshold": (0.0, 1.0),
    "outlier_probability": (0.0, 1.0),
    "field_of_view": (0.0, 2.0 * math.pi),
    "sensor_yaw": (-math.pi, math.pi),
    "logodds_missed": (-FLOAT_MAX, 0.0),
    "logodds_remove": (-FLOAT_MAX, FLOAT_MAX),
    "sensor_x": (-FLOAT_MAX, FLOAT_MAX),
    "sensor_y": (-FLOAT_MAX, FLOAT_MAX),
}
"""Inclusive ROS ranges of core parameters; other numbers are >= 0. ``validate()`` adds the
exact (also exclusive and cross-parameter) rules."""
CORE_CHOICES = {name: " | ".join(choices) for name, choices in (
    ("algorithm", config_rules.ALGORITHMS), ("association", config_rules.ASSOCIATION_MODES),
    ("monte_carlo_weight", config_rules.MONTE_CARLO_WEIGHTS),
    ("resampling", config_rules.RESAMPLING_SCHEMES),
    ("best_particle", config_rules.BEST_PARTICLE_RULES), ("backend", config_rules.BACKENDS))}
"""The allowed values of the core's string parameters, from the tuples ``validate()`` checks."""


@dataclass(frozen=True)
class RosParameter:
    """A ROS-side parameter: default, description and inclusive range (numbers only)."""

    default: object
    description: str
    limits: tuple[float, float] | None = None


ROS_PARAMETERS = {
    "odom_frame": RosParameter("odom", "Odometry frame (REP 105): odometry must be stamped in it "
                                       "('' accepted)."),
    "map_frame": RosParameter("map", "Frame of the pose, path, particles and map outputs."),
    "base_frame": RosParameter("base_link", "Robot frame (REP 105): odometry must have it as "
                                            "child_frame_id ('' accepted)."),
    "sensor_frame": RosParameter("", "Frame the landmark clouds must be in; '' accepts any frame."),
    "pose_estimate": RosParameter("best", "~/pose is the 'best' particle or the weighted 'mean'."),
    "particles_rate": RosParameter(2.0, "Maximum rate of ~/particles (Hz, node time; 0: never).",
                                   (0.0, 1000.0)),
    "markers_rate": RosParameter(1.0, "Maximum rate of ~/landmarks and ~/map_cloud (Hz; 0: never).",
                                 (0.0, 1000.0)),
    "path_rate": RosParameter(1.0, "Maximum rate of ~/path (Hz, node time; 0: never).",
                              (0.0, 1000.0)),
    "max_observation_wait": RosParameter(
        0.5, "How long (s, node time) a cloud waits for odometry that covers its stamp; also how "
             "late (s of stamps) a cloud may arrive and still get its exact interpolated pose.",
        (0.0, 60.0)),
    "map_file": RosParameter("fastslam_map.yaml", "File written by ~/save_map: .csv is CSV, "
                                                  "anything else YAML."),
    "publish_tf": RosParameter(True, "Broadcast map -> odom on /tf (when tf2_ros is installed)."),
}


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


def config_field_descriptions() -> dict[str, str]:
    """Docstrings written under the fields of ``FastSLAMConfig`` (one source for both layers)."""
    try:
        tree = ast.parse(inspect.getsource(FastSLAMConfig))
    except (OSError, TypeError):  # no source installed: descriptions fall back to the name
        return {}
    body = tree.body[0].body
    descriptions = {}
    for statement, following in zip(body, body[1:]):
        if (isinstance(statement, ast.AnnAssign) and isinstance(following, ast.Expr)
                and isinstance(following.value, ast.Constant)
                and isinstance(following.value.value, str)):
            descriptions[statement.target.id] = " ".join(following.value.value.split())
    return descriptions


def parameter_descriptor(description: str, default: object,
                         limits: tuple[float, float] | None) -> ParameterDescriptor:
    """ParameterDescriptor with a description and, for numbers, an inclusive range."""
    descriptor = ParameterDescriptor(description=description)
    if limits is None or isinstance(default, bool):
        return descriptor
    if isinstance(default, int):
        descriptor.integer_range = [IntegerRange(from_value=int(limits[0]), to_value=int(limits[1]),
                                                 step=0)]
    elif isinstance(default, float):
        descriptor.floating_point_range = [FloatingPointRange(
            from_value=float(limits[0]), to_value=float(limits[1]), step=0.0)]
    return descriptor


class FastSLAMNode(Node):
    """Landmark FastSLAM on ``odom`` + ``landmarks``; publishes pose, map, path and particles."""

    def __init__(self, **node_kwargs) -> None:
        """Declare parameters (ParameterError on a bad value), create the filter and the I/O.

        A failed start destroys the half-built node at once: left to the garbage collector, its
        DDS participant would be torn down at some later, arbitrary point (Fast DDS can then
        block the whole process)."""
        super().__init__(NODE_NAME, **node_kwargs)
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
        self.add_on_set_parameters_callback(self._check_parameter_change)
        self.add_post_set_parameters_callback(self._apply_parameter_change)

        started = time.perf_counter()
        self.slam = FastSLAM(self.config)
        """The filter (random generator seeded from the ``seed`` parameter); read it, the node
        feeds it. Built before the subscriptions: the compiled backend is ready (compiled or
        loaded from its cache) before the first message."""
        self.get_logger().info(f"core backend {self.slam.backend} ready in "
                               f"{time.perf_counter() - started:.1f} s")
        self._odometry = OdometryHistory()
        self._pending: list[Observation] = []
        self._newest_stamp: float | None = None
        self._last_cloud_stamp: float | None = None
        self._last_update_stamp = 0.0
        self._map_dirty = False
        self._published_keys: set[int] = set()
        self._path_builder = ros_io.PathBuilder()
        self._diagnostics_throttle = Throttle(1.0 / DIAGNOSTICS_PERIOD)
        self._drops_at_last_diagnostics = 0

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
        self.create_service(Trigger, "~/reset", self._on_reset)
        self.create_service(Trigger, "~/save_map", self._on_save_map)
        self.create_timer(DIAGNOSTICS_PERIOD, self._on_timer)
        self.get_logger().info(
            f"FastSLAM {self.config.algorithm}, {self.config.num_particles} particles, "
            f"association {self.config.association}; map frame '{self.settings['map_frame']}'")

    # --- parameters ----------------------------------------------------------------------------

    def _declare(self, name: str, default: object, descriptor: ParameterDescriptor) -> object:
        """Declare one parameter; a value of the wrong type or range raises ParameterError."""
        try:
            return self.declare_parameter(name, default, descriptor).value
        except ParameterException as error:
            raise ParameterError(f"parameter '{name}': {error}") from None

    def _declare_core_parameters(self) -> FastSLAMConfig:
        """One parameter per FastSLAMConfig field; the validated config built from them."""
        descriptions = config_field_descriptions()
        values = {}
        for field in dataclasses.fields(FastSLAMConfig):
            default = field.default
            description = descriptions.get(field.name, field.name)
            if field.name in CORE_CHOICES:
                description += f" One of: {CORE_CHOICES[field.name]}."
            limits = CORE_RANGES.get(field.name,
                                     (0.0, FLOAT_MAX) if isinstance(default, float) else None)
            values[field.name] = self._declare(field.name, default, parameter_descriptor(
                description + " Fixed at start (restart to change).", default, limits))
        try:
            return FastSLAMConfig(**values).validate()
        except ValueError as error:  # validate() starts its message with the field's name
            name, _, reason = str(error).partition(":")
            raise ParameterError(f"parameter '{name}':{reason}") from None

    def _declare_ros_parameters(self) -> None:
        """Frames, rates and the rest of the ROS side, cached in ``self.settings``."""
        for name, spec in ROS_PARAMETERS.items():
            self._declare(name, spec.default, parameter_descriptor(spec.description, spec.default,
                                                                    spec.limits))
        parameters = [self.get_parameter(name) for name in ROS_PARAMETERS]
        problem = self._ros_parameter_problem(parameters)
        if problem:
            raise ParameterError(problem)
        self._apply_parameter_change(parameters)

    @staticmethod
    def _ros_parameter_problem(parameters: list[Parameter]) -> str:
        """Why these ROS-side values are invalid ('' when they are fine)."""
        for parameter in parameters:
            if parameter.name == "pose_estimate" and parameter.value not in POSE_ESTIMATES:
                return (f"parameter 'pose_estimate': must be one of {POSE_ESTIMATES} "
                        f"(got {parameter.value!r})")
            if parameter.name in REQUIRED_STRINGS and not parameter.value:
                return f"parameter '{parameter.name}': must not be empty"
        return ""

    def _check_parameter_change(self, parameters: list[Parameter]) -> SetParametersResult:
        """Accept runtime changes of ROS-side parameters; core ones need a restart."""
        core_names = {field.name for field in dataclasses.fields(FastSLAMConfig)}
        for parameter in parameters:
            if parameter.name in core_names:
                return SetParametersResult(successful=False, reason=(
                    f"{parameter.name}: core parameters are fixed while the filter runs; restart "
                    "the node with the new value"))
        problem = self._ros_parameter_problem(parameters)
        return SetParametersResult(successful=not problem, reason=problem)

    def _apply_parameter_change(self, parameters: list[Parameter]) -> None:
        """Cache the ROS-side values the callbacks read; a new rate restarts its throttle."""
        for parameter in parameters:
            if parameter.name in ROS_PARAMETERS:
                self.settings[parameter.name] = parameter.value
            if parameter.name in THROTTLED_OUTPUTS:
                self._throttles[parameter.name] = Throttle(parameter.value)

    # --- inputs --------------------------------------------------------------------------------

    def on_odometry(self, msg: Odometry) -> None:
        """Subscription callback: store the odometry pose, then run what it makes ready."""
        self.stats["received_odom"] += 1
        try:
            self._handle_odometry(msg)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"odometry callback failed: {error!r}")

    def on_landmarks(self, msg: PointCloud2) -> None:
        """Subscription callback: convert the cloud to range/bearing and queue it by stamp."""
        self.stats["received_landmarks"] += 1
        try:
            self._handle_landmarks(msg)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"landmarks callback failed: {error!r}")

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
        stamp = ros_io.stamp_to_seconds(msg.header.stamp)
        self._check_time_jump(stamp)
        latest = self._odometry.latest_stamp
        if latest is not None and stamp == latest:
            return self._drop("duplicate_stamp", f"odometry with a repeated stamp {stamp:.9f}")
        if latest is not None and stamp < latest:
            return self._drop("time_backwards", f"odometry stamp {stamp:.9f} is older than the "
                                                f"previous one ({latest:.9f})")
        if latest is None:
            self.slam.reset(initial_pose=tuple(pose))  # map frame starts at the first odometry
        self._odometry.append(stamp, pose)
        self.stats["used_odom"] += 1
        now = self._now()
        self._process_ready(now)
        self._advance_idle()
        self._publish_throttled(now)

    def _handle_landmarks(self, msg: PointCloud2) -> None:
        if not self._frame_ok("sensor_frame", msg.header.frame_id, "landmark cloud"):
            return
        try:
            cloud = ros_io.read_landmark_cloud(msg)
        except ros_io.MalformedCloudError as error:
            return self._drop("malformed_cloud", f"landmark cloud dropped: {error}")
        stamp = ros_io.stamp_to_seconds(msg.header.stamp)
        self._check_time_jump(stamp)
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
        positive = ~finite | (ranges > 0.0)
        in_range = ~finite | (ranges <= self.config.max_range)
        keep = finite & positive & in_range
        self._count_points("nan", finite, "non-finite x/y")
        self._count_points("negative_range", positive, "range <= 0 (point at the sensor origin)")
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

    def _check_time_jump(self, stamp: float) -> None:
        """Reset the filter when time went backwards (looped bag); buffered clouds go in first."""
        if self._newest_stamp is not None and stamp < self._newest_stamp - TIME_JUMP_BACK:
            self.get_logger().warning(
                f"time went backwards from {self._newest_stamp:.3f} s to {stamp:.3f} s "
                "(looped bag?): resetting the filter", throttle_duration_sec=5.0)
            self.stats["time_jumps"] += 1
            self._process_ready(self._now(), force=True)
            self.reset()
        self._newest_stamp = stamp if self._newest_stamp is None else max(self._newest_stamp, stamp)

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
        report = self.slam.update(observation.ranges, observation.bearings, ids=observation.ids,
                                   stamp=observation.stamp)
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
        # map -> odom = (map -> base) * (odom -> base)^-1, both at the observation's time.
        map_to_odom = compose(pose, relative_pose(self._odometry.anchor_pose, np.zeros(3)))
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
        stamps, poses = self.slam.best_path()
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
        self._publish(self._markers_pub, ros_io.landmark_markers(header, landmark_map, removed))
        self._publish(self._map_cloud_pub, ros_io.map_cloud(header, landmark_map))
        self._published_keys = keys
        self._map_dirty = False

    def _publish_diagnostics(self) -> None:
        """/diagnostics: every counter; WARN when input was dropped since the last report."""
        drops = sum(v for k, v in self.stats.items() if k.startswith("dropped_"))
        new_drops = drops - self._drops_at_last_diagnostics
        self._drops_at_last_diagnostics = drops
        status = DiagnosticStatus(
            level=DiagnosticStatus.WARN if new_drops else DiagnosticStatus.OK,
            name=f"{self.get_name()}: filter", hardware_id=self.get_fully_qualified_name(),
            message=f"{new_drops} input(s) dropped since last report" if new_drops else "running",
            values=[KeyValue(key=k, value=str(v)) for k, v in self.stats.items()]
            + [KeyValue(key="queued_observations", value=str(len(self._pending)))])
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
        map_file = self.settings["map_file"]
        try:
            landmark_map = self.slam.best_map()
            written = ros_io.write_map_file(map_file, landmark_map, self.settings["map_frame"],
                                            self._last_update_stamp)
            response.success = True
            response.message = f"{len(landmark_map.keys)} landmarks written to {written}"
        except Exception as error:  # noqa: BLE001 - report the failure to the caller
            response.success, response.message = False, f"cannot write '{map_file}': {error}"
        return response

    def destroy_node(self) -> None:
        """Destroy, then log the counters (after destruction the log skips /rosout, whose
        publisher is gone when Ctrl-C has already shut the context down)."""
        super().destroy_node()
        counts = ", ".join(f"{key}={value}" for key, value in self.stats.items() if value)
        self.get_logger().info(f"input summary: {counts or 'no input received'}")


def main(args: list[str] | None = None) -> int:
    """Console entry point ``fastslam_node``; exit status 1 on a bad parameter."""
    rclpy.init(args=args)
    try:
        node = FastSLAMNode()
    except ParameterError as error:
        print(f"fastslam_node: {error}", file=sys.stderr)
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


if __name__ == "__main__":
    sys.exit(main())
