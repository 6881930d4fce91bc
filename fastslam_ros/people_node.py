"""ROS 2 node around the people tracker: map, scans and odometry in; robot pose and people out.

Node ``people_tracker`` (console script ``people_tracker_node``). The map comes from ``map``
(``nav_msgs/OccupancyGrid``, transient local, as nav2's map_server publishes) or from the
``map_file`` parameter (a nav2 map YAML). Scans wait, like the SLAM node's clouds, for the
odometry that covers their stamp and are used at the robot pose interpolated there
(core.timing). ``initialpose`` (RViz's "2D Pose Estimate") places the robot; without it the
tracker localizes globally over the free space. Bad input is counted, warned about (throttled)
and dropped; the counters are on ``/diagnostics``. See docs/people.md.
"""
from __future__ import annotations

import bisect
import sys
from dataclasses import dataclass
from typing import Callable

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from sensor_msgs.msg import LaserScan, PointCloud2
from std_msgs.msg import Header
from visualization_msgs.msg import MarkerArray

from fastslam_ros import people_io, ros_io
from fastslam_ros.core.geometry import compose, relative_pose
from fastslam_ros.core.params import check_fields, parameter, specs
from fastslam_ros.core.timing import OdometryHistory, Throttle
from fastslam_ros.node import (DIAGNOSTICS_PERIOD, INPUT_QOS, LATEST_QOS, MAP_QOS, STREAM_QOS,
                               TIME_JUMP_BACK, ParameterError, parameter_descriptor, run_node)
from fastslam_ros.people import PeopleTracker, Scan, TrackerSettings

try:  # Only a full ROS install has tf2_ros; ~/map_to_odom carries the same transform anyway.
    from tf2_ros import TransformBroadcaster
except ImportError:
    TransformBroadcaster = None

NODE_NAME = "people_tracker"
POSE_ESTIMATES = ("best", "mean")
COUNTERS = (
    "received_map", "received_scan", "received_odom", "received_initialpose",
    "used_map", "used_scan", "used_odom", "used_initialpose",
    "late_scans", "stale_scans", "resets", "time_jumps",
    "people_created", "people_removed", "global_localizations", "converged",
    "dropped_malformed_map", "dropped_malformed_scan", "dropped_wrong_frame",
    "dropped_invalid_quaternion", "dropped_nan", "dropped_duplicate_stamp",
    "dropped_time_backwards", "dropped_stale", "dropped_no_map", "dropped_internal_error",
)


@dataclass(frozen=True)
class NodeSettings:
    """The ROS side of the node: frames, map source, output rates."""

    map_frame: str = parameter("map", "Frame of the map, the pose, the particles and the people.")
    odom_frame: str = parameter("odom", "Odometry frame (REP 105); '' accepts any.")
    base_frame: str = parameter("base_link", "Robot frame: odometry's child_frame_id; '' "
                                             "accepts any.")
    scan_frame: str = parameter("", "Frame the scans must be in; '' accepts any.")
    map_file: str = parameter("", "nav2 map YAML to load at start; '': subscribe to 'map'.")
    pose_estimate: str = parameter("mean", "~/pose is the weighted 'mean' of the robot "
                                           "particles or the 'best' one.", choices=POSE_ESTIMATES)
    particles_rate: float = parameter(2.0, "Maximum rate of ~/particles (Hz; 0: never).",
                                      low=0.0, high=1000.0)
    markers_rate: float = parameter(5.0, "Maximum rate of ~/people_markers (Hz; 0: never).",
                                    low=0.0, high=1000.0)
    max_observation_wait: float = parameter(
        0.5, "How long (s) a scan waits for odometry covering its stamp.", low=0.0, high=60.0)
    publish_tf: bool = parameter(True, "Broadcast map -> odom on /tf (when tf2_ros is "
                                       "installed).")


SETTINGS_CLASSES = (TrackerSettings, NodeSettings)


def parameter_specs() -> dict:
    """{name: (default, spec)} of every parameter of the node, tracker first."""
    merged = {}
    for settings in SETTINGS_CLASSES:
        merged.update(specs(settings))
    return merged


@dataclass
class PendingScan:
    """A scan waiting for odometry that covers its stamp."""

    stamp: float
    scan: Scan
    arrival: float


class PeopleTrackerNode(Node):
    """The conditional particle filter on ``map`` + ``scan`` + ``odom``."""

    def __init__(self, **node_kwargs) -> None:
        super().__init__(NODE_NAME, **node_kwargs)
        try:
            self._set_up()
        except BaseException:
            Node.destroy_node(self)
            raise

    def _set_up(self) -> None:
        self.output_listeners: list[Callable[[str, object], None]] = []
        self.publish_to_dds = True
        self.stats: dict[str, int] = dict.fromkeys(COUNTERS, 0)
        self.tracker_settings, self.settings = self._declare_parameters()
        self.tracker = PeopleTracker(self.tracker_settings)
        self._odometry = OdometryHistory()
        self._pending: list[PendingScan] = []
        self._initial: tuple[np.ndarray, np.ndarray] | None = None
        self._newest_stamp: float | None = None
        self._last_scan_stamp: float | None = None
        self._published_keys: set[int] = set()
        self._particles_throttle = Throttle(self.settings.particles_rate)
        self._markers_throttle = Throttle(self.settings.markers_rate)
        self._diagnostics_throttle = Throttle(1.0 / DIAGNOSTICS_PERIOD)
        self._drops_at_last_diagnostics = 0

        self._pose_pub = self.create_publisher(PoseWithCovarianceStamped, "~/pose", STREAM_QOS)
        self._particles_pub = self.create_publisher(PoseArray, "~/particles", LATEST_QOS)
        self._people_pub = self.create_publisher(PointCloud2, "~/people", STREAM_QOS)
        self._markers_pub = self.create_publisher(MarkerArray, "~/people_markers", STREAM_QOS)
        self._map_to_odom_pub = self.create_publisher(TransformStamped, "~/map_to_odom",
                                                      STREAM_QOS)
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", STREAM_QOS)
        self._tf_broadcaster = TransformBroadcaster(self) if TransformBroadcaster else None
        if self.settings.map_file:
            try:
                grid = people_io.load_map_file(self.settings.map_file,
                                               self.tracker_settings.likelihood_max_distance)
            except people_io.MalformedMapError as error:
                raise ParameterError(f"parameter 'map_file': {error}") from None
            self._use_map(grid)
        else:
            self.create_subscription(OccupancyGrid, "map", self.on_map, MAP_QOS)
        self.create_subscription(LaserScan, "scan", self.on_scan, INPUT_QOS)
        self.create_subscription(Odometry, "odom", self.on_odometry, INPUT_QOS)
        self.create_subscription(PoseWithCovarianceStamped, "initialpose", self.on_initial_pose,
                                 STREAM_QOS)
        self.create_timer(DIAGNOSTICS_PERIOD, self._on_timer)
        s = self.tracker_settings
        self.get_logger().info(
            f"people tracker: {s.num_particles} robot particles ({s.global_particles} while "
            f"localizing globally) x {s.max_people} people x {s.people_particles}; map "
            f"{'file ' + self.settings.map_file if self.settings.map_file else 'topic'}")

    # --- parameters ----------------------------------------------------------------------------

    def _declare_parameters(self) -> tuple[TrackerSettings, NodeSettings]:
        """One ROS parameter per settings field; ParameterError names a bad or unknown one."""
        values = {}
        for name, (default, spec) in parameter_specs().items():
            try:
                values[name] = self.declare_parameter(
                    name, default, parameter_descriptor(default, spec)).value
            except ParameterException as error:
                raise ParameterError(f"parameter '{name}': {error}") from None
        unknown = sorted(set(getattr(self, "_parameter_overrides", {})) - set(values)
                         - {"use_sim_time"})
        if unknown:
            raise ParameterError(f"unknown parameter(s): {', '.join(unknown)}")
        built = []
        for settings_class in SETTINGS_CLASSES:
            names = specs(settings_class)
            try:
                settings = settings_class(**{n: values[n] for n in names})
                check_fields(settings)
                if settings_class is TrackerSettings:
                    settings.validate()
            except ValueError as error:
                name, _, reason = str(error).partition(":")
                raise ParameterError(f"parameter '{name}':{reason}") from None
            built.append(settings)
        return built[0], built[1]

    # --- inputs --------------------------------------------------------------------------------

    def _guard(self, what: str, handler, msg) -> None:
        try:
            handler(msg)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"{what} callback failed: {error!r}")

    def on_map(self, msg: OccupancyGrid) -> None:
        self.stats["received_map"] += 1
        self._guard("map", self._handle_map, msg)

    def on_scan(self, msg: LaserScan) -> None:
        self.stats["received_scan"] += 1
        self._guard("scan", self._handle_scan, msg)

    def on_odometry(self, msg: Odometry) -> None:
        self.stats["received_odom"] += 1
        self._guard("odometry", self._handle_odometry, msg)

    def on_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        self.stats["received_initialpose"] += 1
        self._guard("initialpose", self._handle_initial_pose, msg)

    def _handle_map(self, msg: OccupancyGrid) -> None:
        if not self._frame_ok("map_frame", msg.header.frame_id, "map"):
            return
        try:
            grid = people_io.read_occupancy_grid(msg,
                                                 self.tracker_settings.likelihood_max_distance)
        except (people_io.MalformedMapError, ros_io.InvalidQuaternionError) as error:
            return self._drop("malformed_map", f"map dropped: {error}")
        self._use_map(grid)

    def _use_map(self, grid) -> None:
        self.tracker.set_map(grid)
        self.stats["used_map"] += 1
        self._start_filter()

    def _start_filter(self) -> None:
        """(Re)start the particles: at the initial pose if one was given, else globally."""
        if self._initial is not None:
            self.tracker.reset(*self._initial)
        else:
            self.tracker.reset()
            self.stats["global_localizations"] += 1

    def _handle_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        if not self._frame_ok("map_frame", msg.header.frame_id, "initial pose"):
            return
        try:
            self._initial = people_io.initial_pose(msg)
        except ros_io.InvalidQuaternionError as error:
            return self._drop("invalid_quaternion", f"initial pose dropped: {error}")
        except ros_io.NonFiniteError as error:
            return self._drop("nan", f"initial pose dropped: {error}")
        self.stats["used_initialpose"] += 1
        if self.tracker.grid is not None:
            self.tracker.reset(*self._initial)

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
            return self._drop("time_backwards", f"odometry stamp {stamp:.9f} is older than "
                                                f"the previous one ({latest:.9f})")
        self._odometry.append(stamp, pose)
        self.stats["used_odom"] += 1
        now = self._now()
        self._process_ready(now)
        self._advance_idle()
        self._publish_throttled(now)

    def _handle_scan(self, msg: LaserScan) -> None:
        if not self._frame_ok("scan_frame", msg.header.frame_id, "scan"):
            return
        try:
            scan = people_io.read_scan(msg)
        except people_io.MalformedScanError as error:
            return self._drop("malformed_scan", f"scan dropped: {error}")
        stamp = ros_io.stamp_to_seconds(msg.header.stamp)
        self._check_time_jump(stamp)
        if stamp == self._last_scan_stamp or any(p.stamp == stamp for p in self._pending):
            return self._drop("duplicate_stamp", f"scan with a repeated stamp {stamp:.9f}")
        now = self._now()
        bisect.insort(self._pending, PendingScan(stamp, scan, now), key=lambda p: p.stamp)
        self._process_ready(now)
        self._publish_throttled(now)

    def _frame_ok(self, parameter_name: str, frame_id: str, what: str) -> bool:
        frame, expected = frame_id.lstrip("/"), getattr(self.settings, parameter_name)
        if not frame or not expected or frame == expected:
            return True
        self._drop("wrong_frame", f"{what} frame '{frame}' is not '{expected}' "
                                  f"(parameter {parameter_name})")
        return False

    def _drop(self, reason: str, message: str, count: int = 1) -> None:
        self.stats[f"dropped_{reason}"] += count
        self.get_logger().warning(f"{message} [dropped_{reason}]", throttle_duration_sec=5.0)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _check_time_jump(self, stamp: float) -> None:
        """Restart (keeping the map) when time went backwards (a looped bag)."""
        if self._newest_stamp is not None and stamp < self._newest_stamp - TIME_JUMP_BACK:
            self.get_logger().warning(
                f"time went backwards from {self._newest_stamp:.3f} s to {stamp:.3f} s "
                "(looped bag?): restarting the tracker", throttle_duration_sec=5.0)
            self.stats["time_jumps"] += 1
            self.reset()
        self._newest_stamp = stamp if self._newest_stamp is None else max(self._newest_stamp,
                                                                          stamp)

    # --- filter --------------------------------------------------------------------------------

    def _process_ready(self, now: float, force: bool = False) -> None:
        """Run queued scans, oldest first, whose odometry has arrived (see the SLAM node)."""
        while self._pending:
            pending = self._pending[0]
            waited_enough = force or now - pending.arrival > self.settings.max_observation_wait
            if not self._odometry.covers(pending.stamp):
                if not waited_enough:
                    return
                if self._odometry.latest_stamp is None:
                    self._pending.pop(0)
                    self._drop("stale", "scan dropped: no odometry has arrived")
                    continue
                self.stats["stale_scans"] += 1
            self._pending.pop(0)
            if not self.tracker.ready:
                self._drop("no_map", "scan dropped: no map yet")
                continue
            self._update(pending)

    def _advance_idle(self) -> None:
        latest = self._odometry.latest_stamp
        if latest is not None:
            for pose_from, pose_to in self._odometry.advance(
                    latest - self.settings.max_observation_wait):
                self.tracker.predict(pose_from, pose_to)

    def _update(self, pending: PendingScan) -> None:
        if pending.stamp < self._odometry.anchor_stamp:
            self.stats["late_scans"] += 1
        for pose_from, pose_to in self._odometry.advance(pending.stamp):
            self.tracker.predict(pose_from, pose_to)
        localizing = self.tracker.globally_localizing
        report = self.tracker.update(pending.stamp, pending.scan)
        if localizing and report.converged:
            self.stats["converged"] += 1
        self.stats["used_scan"] += 1
        self.stats["people_created"] += report.created
        self.stats["people_removed"] += report.removed
        self._last_scan_stamp = pending.stamp
        self._publish_estimate(pending.stamp)

    def reset(self) -> None:
        """Forget odometry, queued scans and people; keep the map and restart the particles."""
        self._odometry = OdometryHistory()
        self._pending.clear()
        self._newest_stamp = None
        self._last_scan_stamp = None
        self.stats["resets"] += 1
        if self.tracker.grid is not None:
            self._start_filter()

    def flush(self) -> None:
        """Run every queued scan now (end of a bag) and publish the throttled outputs once."""
        self._process_ready(self._now(), force=True)
        if self.stats["used_scan"]:
            stamp = self._last_scan_stamp
            if self.settings.particles_rate > 0.0:
                self._publish_particles(stamp)
            if self.settings.markers_rate > 0.0:
                self._publish_markers(stamp)
        self._publish_diagnostics()

    # --- outputs -------------------------------------------------------------------------------

    def _publish(self, publisher, msg) -> None:
        if self.publish_to_dds:
            publisher.publish(msg)
        for listener in self.output_listeners:
            listener(publisher.topic_name, msg)

    def _header(self, stamp: float) -> Header:
        return Header(stamp=ros_io.seconds_to_stamp(stamp), frame_id=self.settings.map_frame)

    def _publish_estimate(self, stamp: float) -> None:
        """~/pose, ~/people and map -> odom at the scan's stamp."""
        header = self._header(stamp)
        mean, covariance = self.tracker.mean_pose_and_covariance()
        pose = mean if self.settings.pose_estimate == "mean" else self.tracker.best_pose()
        self._publish(self._pose_pub, ros_io.pose_with_covariance(header, pose, covariance))
        self._publish(self._people_pub, people_io.people_cloud(header, self.tracker.people_of()))
        map_to_odom = compose(pose, relative_pose(self._odometry.anchor_pose, np.zeros(3)))
        transform = ros_io.transform(header, self.settings.odom_frame, map_to_odom)
        self._publish(self._map_to_odom_pub, transform)
        if self.settings.publish_tf and self._tf_broadcaster is not None:
            self._tf_broadcaster.sendTransform(transform)

    def _publish_throttled(self, now: float) -> None:
        if self.stats["used_scan"]:
            if self._particles_throttle.due(now):
                self._publish_particles(self._last_scan_stamp)
            if self._markers_throttle.due(now):
                self._publish_markers(self._last_scan_stamp)
        if self._diagnostics_throttle.due(now):
            self._publish_diagnostics()

    def _publish_particles(self, stamp: float) -> None:
        self._publish(self._particles_pub,
                      ros_io.pose_array(self._header(stamp), self.tracker.poses))

    def _publish_markers(self, stamp: float) -> None:
        people = self.tracker.people_of()
        keys = set(people.keys.tolist())
        removed = sorted(self._published_keys - keys)
        self._publish(self._markers_pub,
                      people_io.people_markers(self._header(stamp), people, removed))
        self._published_keys = keys

    def _publish_diagnostics(self) -> None:
        drops = sum(v for k, v in self.stats.items() if k.startswith("dropped_"))
        new_drops = drops - self._drops_at_last_diagnostics
        self._drops_at_last_diagnostics = drops
        tracker = self.tracker
        state = [KeyValue(key="queued_scans", value=str(len(self._pending))),
                 KeyValue(key="robot_particles", value=str(tracker.num_particles)),
                 KeyValue(key="localizing_globally", value=str(tracker.globally_localizing)),
                 KeyValue(key="map_received", value=str(tracker.grid is not None))]
        if tracker.ready:
            state.append(KeyValue(key="people", value=str(len(tracker.people_of().keys))))
        level = DiagnosticStatus.WARN if new_drops or tracker.grid is None else DiagnosticStatus.OK
        message = (f"{new_drops} input(s) dropped since last report" if new_drops
                   else "waiting for a map" if tracker.grid is None else "running")
        status = DiagnosticStatus(
            level=level, name=f"{self.get_name()}: tracker",
            hardware_id=self.get_fully_qualified_name(), message=message,
            values=[KeyValue(key=k, value=str(v)) for k, v in self.stats.items()] + state)
        self._publish(self._diagnostics_pub,
                      DiagnosticArray(header=Header(stamp=self.get_clock().now().to_msg()),
                                      status=[status]))

    def _on_timer(self) -> None:
        try:
            now = self._now()
            self._process_ready(now)
            self._publish_throttled(now)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"timer callback failed: {error!r}")

    def destroy_node(self) -> None:
        super().destroy_node()
        counts = ", ".join(f"{key}={value}" for key, value in self.stats.items() if value)
        self.get_logger().info(f"input summary: {counts or 'no input received'}")


USAGE = """People tracker on a known map: nav_msgs/OccupancyGrid on map (or map_file),
sensor_msgs/LaserScan on scan, odometry on odom and initialpose in; robot pose, particles,
people and their markers out (docs/people.md).

ROS arguments follow --ros-args, as for every ROS 2 node:
  people_tracker_node --ros-args --params-file config/people_tracker.yaml -r scan:=/base_scan"""


def main(args: list[str] | None = None) -> int:
    """Console entry point ``people_tracker_node``; exit status 1 on a bad parameter."""
    return run_node("people_tracker_node", NODE_NAME, USAGE, PeopleTrackerNode, args)


if __name__ == "__main__":
    sys.exit(main())
