# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""ROS 2 node around the FastSLAM core: time alignment of odometry and landmark clouds, outputs.

The node does no estimation math. It reads odometry and landmark clouds, feeds the filter in
stamp order (the particles are predicted to each observation's stamp with odometry interpolated
there), and publishes the estimate. The input gates, the parameters, /diagnostics and
``_publish`` are the ones every node of the package shares (``node_base.FilterNode``);
throttled outputs follow the node clock inside the callbacks, so a replay that calls the
callbacks directly and sets the clock (``tools/bags/in_process.py``) gets the same outputs as a
live run. See docs/node.md for the interface and the parameters.
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from os import PathLike
from typing import Sequence

import numpy as np
from diagnostic_msgs.msg import KeyValue
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
from nav_msgs.msg import Odometry, Path
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from fastslam_ros import map_files, node_console, ros_io, ros_markers
from fastslam_ros.core import FastSLAM, FastSLAMConfig
from fastslam_ros.core.association import association_score
from fastslam_ros.core.backend import kernels_pending
from fastslam_ros.core.map_refinement import refine_best_map
from fastslam_ros.core.observation import MIN_OBSERVATION_RANGE
from fastslam_ros.core.params import ParameterValueError, check_fields, parameter, specs
from fastslam_ros.core.path_history import decimation
from fastslam_ros.node_support.sensor_reach import ReachCheck
from fastslam_ros.output import check_output
from fastslam_ros.node_base import INPUT_QOS, LATEST_QOS, MAP_QOS, STREAM_QOS, FilterNode
from fastslam_ros.node_console import run_node
from fastslam_ros.node_diagnostics import DIAGNOSTICS_PERIOD
from fastslam_ros.node_parameters import (ParameterError, max_speed_parameter,
                                          max_yaw_rate_parameter)

NODE_NAME = "fastslam"

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
    "relocalizations",        # localization: particles redrawn at a pose found from a reading
    "fault_recoveries",       # fault_recovery_matches: the map's rotated copy moved back onto it
    "smoother_solves", "smoother_failures",  # smoothing_period: solves that gave a pose or not
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
DIAGNOSED = (("late_observations", "clouds older than the filter's time"),
             ("stale_observations", "clouds used without their odometry"),
             ("filter_recoveries", "filter state repaired"),
             ("odometry_jumps", "odometry jumps bridged"),
             ("time_jumps", "time jumps"))
"""Counters whose growth /diagnostics reports (after drops, lost messages, silence and lag)."""


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
        "", "Frame the landmark clouds must be in; '': the first cloud's frame.")
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
        "Not empty. Its folder must exist; an existing file is replaced only with "
        "save_map_overwrite.")
    save_map_overwrite: bool = parameter(
        False, "Let ~/save_map replace an existing save_map_file (a regular file, or a link: "
        "the link is replaced, never what it points to); false refuses it.")
    publish_tf: bool = parameter(
        True, "Broadcast map -> odom on /tf (when tf2_ros is installed).")
    max_speed: float = max_speed_parameter()
    max_yaw_rate: float = max_yaw_rate_parameter()
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


@dataclass
class Observation:
    """A landmark cloud ready for the filter: range (m) and bearing (rad) in the sensor frame."""

    stamp: float
    ranges: np.ndarray
    bearings: np.ndarray
    ids: np.ndarray | None
    arrival: float
    """Node-clock time (s) at which the cloud arrived, for the max_observation_wait bound."""

    @property
    def odometry_until(self) -> float:
        """A cloud waits for the odometry of its own stamp."""
        return self.stamp


class FastSLAMNode(FilterNode):
    """Landmark FastSLAM on ``odom`` + ``landmarks``; publishes pose, map, path and particles."""

    NODE_NAME = NODE_NAME

    def _set_up(self) -> None:
        """Everything of the start after the rcl node exists."""
        self._start_inputs(COUNTERS, "landmarks", "landmark cloud", "stale_observations",
                           THROTTLED_OUTPUTS, DIAGNOSED)
        self.config = self._declare_parameters(
            CORE_PARAMETERS, lambda **values: FastSLAMConfig(**values).validate(),
            NODE_PARAMETERS, NodeSettings)

        started = time.perf_counter()
        if kernels_pending(self.config.backend):
            self.get_logger().info("compiling the filter's kernels (first start only; later "
                                   "starts load them from numba's cache) ...")
        self.slam = FastSLAM(self.config)
        """The filter (random generator seeded from the ``seed`` parameter); read it, the node
        feeds it. Built before the subscriptions: the compiled backend is ready (compiled or
        loaded from its cache) before the first message."""
        if not self.context.ok():  # Ctrl-C while numba compiled, which may swallow it
            raise KeyboardInterrupt
        self._initial_pose: tuple[np.ndarray, np.ndarray] | None = None
        """A pose given on ``initialpose`` before the first odometry, applied with it."""
        self.get_logger().info(f"core backend {self.slam.backend} ready in "
                               f"{time.perf_counter() - started:.1f} s")
        self._last_update_stamp = 0.0
        self._map_dirty = False
        self._published_keys: set[int] = set()
        self._path_builder = ros_io.PathBuilder()
        self._marker_builder = ros_markers.MarkerBuilder()
        self._reach_check = ReachCheck(self.config.max_range, self.config.field_of_view)
        """Warns once when the first observations do not fit max_range / field_of_view."""

        self._pose_pub = self.create_publisher(PoseWithCovarianceStamped, "~/pose", STREAM_QOS)
        self._path_pub = self.create_publisher(Path, "~/path", LATEST_QOS)
        self._markers_pub = self.create_publisher(MarkerArray, "~/landmarks", MAP_QOS)
        self._map_cloud_pub = self.create_publisher(PointCloud2, "~/map_cloud", MAP_QOS)
        self._particles_pub = self.create_publisher(PoseArray, "~/particles", LATEST_QOS)
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
            except map_files.MapFileError as error:
                raise ParameterError(f"parameter 'map_file': {error}") from None
        elif self.config.mode == "localization":
            raise ParameterError("parameters 'mode', 'map_file': mode localization needs a "
                                 "map_file to localize on")
        self.get_logger().info(
            f"FastSLAM {self.config.algorithm}, {self.config.num_particles} particles, "
            f"association {self.config.association}; map frame '{self.settings['map_frame']}'")

    # --- inputs --------------------------------------------------------------------------------

    def on_landmarks(self, msg: PointCloud2) -> None:
        """Subscription callback: convert the cloud to range/bearing and queue it by stamp."""
        self.stats["received_landmarks"] += 1
        self._run_callback("landmarks", self._handle_landmarks, msg)

    def on_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        """Subscription callback (RViz "2D Pose Estimate"): redraw the particles around the
        given map-frame pose with its covariance."""
        self._run_callback("initialpose", self._handle_initial_pose, msg)

    def _handle_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        given = self._initial_pose_input(msg)
        if given is None:
            return
        pose, covariance = given
        self.stats["initial_poses"] += 1
        self.get_logger().info(f"initial pose ({pose[0]:.2f}, {pose[1]:.2f}, {pose[2]:.2f}): "
                               "particles redrawn around it")
        if self._odometry.latest_stamp is None:
            self._initial_pose = (pose, covariance)  # the first odometry would reset it
        else:
            self._process_ready(self._now(), force=True)
            self.slam.initialize_pose(pose, covariance)
        self._publish_particles()

    def _on_first_odometry(self, pose: np.ndarray) -> None:
        self.slam.reset(initial_pose=tuple(pose))  # map frame starts at the first odometry
        if self._initial_pose is not None:
            self.slam.initialize_pose(*self._initial_pose)

    def _handle_landmarks(self, msg: PointCloud2) -> None:
        if not self._sensor_frame_ok("sensor_frame", msg.header.frame_id, "landmark cloud"):
            return
        size, cap = ros_io.cloud_size(msg), self.settings["max_observations_per_cloud"]
        if size > cap:
            return self._drop("oversized_cloud", f"landmark cloud of {size} points dropped "
                                                 f"(max_observations_per_cloud {cap})")
        try:
            cloud = ros_io.read_landmark_cloud(msg)
        except ros_io.MalformedCloudError as error:
            return self._drop("malformed_cloud", f"landmark cloud dropped: {error}")
        now = self._now()
        stamp = self._reading_stamp(msg.header.stamp, "landmarks", now)
        if stamp is None:
            return
        self._queue(self._observation(cloud, stamp, now), now)

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
        bearings = np.arctan2(cloud.y, cloud.x)
        if self._reach_check.problems is None:  # still sampling the sensor's reach
            self._check_reach(ranges[finite], bearings[finite])
        ids = cloud.ids
        if self.config.association == "known":
            labelled = (np.zeros_like(keep) if ids is None else ids >= 0) | ~keep
            self._count_points("missing_id", labelled,
                               "no id (-1 or no 'id' field) with association 'known'")
            keep &= labelled
        if keep.size and not keep.any():
            return None
        return Observation(stamp=stamp, ranges=ranges[keep], bearings=bearings[keep],
                           ids=None if ids is None else ids[keep], arrival=arrival)

    def _check_reach(self, ranges: np.ndarray, bearings: np.ndarray) -> None:
        """Warn once, and keep /diagnostics at WARN, when the sensor seems misdescribed."""
        for problem in self._reach_check.add(ranges, bearings) or []:
            self.get_logger().warning(f"sensor reach: {problem}")

    def _standing_problems(self) -> list[str]:
        return [f"sensor reach: {problem}" for problem in self._reach_check.problems or []]

    def _count_points(self, reason: str, valid: np.ndarray, what: str) -> None:
        dropped = valid.size - int(np.count_nonzero(valid))
        if dropped:
            self._drop(reason, f"{dropped} landmark point(s) dropped: {what}", dropped)

    # --- filter --------------------------------------------------------------------------------

    def _predict(self, pose_from: np.ndarray, pose_to: np.ndarray) -> None:
        self.slam.predict(pose_from, pose_to)

    def _smoother_counts(self) -> tuple[int, int]:
        """(solves, failures) of the filter's smoother ((0, 0) without one)."""
        smoother = self.slam.smoother
        return (0, 0) if smoother is None else (smoother.solves, smoother.failures)

    def _update(self, observation: Observation) -> None:
        """Predict to the observation's stamp, update, publish the per-observation outputs."""
        self._predict_to(observation.stamp, "late_observations")
        # Only labelled observations are scored: a cloud whose ids are all -1 (unknown) scores
        # nothing, and reading the best particle's map for it would cost more than the update.
        check_ids = (observation.ids is not None and self.config.association != "known"
                     and bool((observation.ids >= 0).any()))
        labels_before = (self.slam.particle_map(self.slam.best_index())[3] if check_ids
                         else None)
        recoveries, relocalizations = self.slam.num_recoveries, self.slam.num_relocalizations
        fault_recoveries = self.slam.num_fault_recoveries
        solves, failures = self._smoother_counts()
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
            self._warn("filter_recoveries", "the filter's state was not finite after an update: "
                       "repaired from the finite particles (or reset) [filter_recoveries]")
        self.stats["relocalizations"] += self.slam.num_relocalizations - relocalizations
        self.stats["fault_recoveries"] += self.slam.num_fault_recoveries - fault_recoveries
        solves_now, failures_now = self._smoother_counts()
        self.stats["smoother_solves"] += max(solves_now - solves, 0)
        if failures_now > failures:
            self.stats["smoother_failures"] += failures_now - failures
            self._warn("smoother_failures", "the online least squares (smoothing_period) gave "
                       "no pose: the estimate follows the particles' mean motion from the last "
                       "solve [smoother_failures]")
        self._note_lag(observation.stamp)
        if check_ids:
            checked, correct = association_score(observation.ids, report.is_new,
                                                 report.associated_ids, labels_before)
            self.stats["associations_checked"] += checked
            self.stats["associations_correct"] += correct
        self.stats["used_landmarks"] += 1
        self.stats["observations_used"] += len(observation.ranges)
        self._last_reading_stamp = observation.stamp
        self._last_update_stamp = observation.stamp
        self._map_dirty = True
        self._publish_pose()

    def reset(self) -> None:
        """Forget the map, the trajectory and all buffered input; the next odometry restarts."""
        self.slam.reset()
        self._reset_inputs()
        self._map_dirty = True
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

    def _header(self) -> Header:
        """Map-frame header at the time of the latest update."""
        return self._map_header(self._last_update_stamp)

    def _estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """Pose per ``pose_estimate`` and the covariance of the particle spread (the
        smoother's pose and covariance with ``smoothing_period``)."""
        mean, covariance = self.slam.mean_pose_and_covariance()
        smoothed = self.slam.smoothed_pose()
        if smoothed is not None:
            return smoothed, self.slam.smoothed_covariance()
        best = self.settings["pose_estimate"] == "best"
        return (self.slam.best_pose() if best else mean), covariance

    def _publish_pose(self) -> None:
        """~/pose and map -> odom at the latest observation (every observation: cheap)."""
        header = self._header()
        pose, covariance = self._estimate()
        self._publish(self._pose_pub, self._pose_message(header, pose, covariance))
        self._publish_map_to_odom(header, pose)

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
        """~/path: the best particle's path (the smoother's with ``smoothing_period``),
        decimated to at most path_max_poses."""
        stamps, poses = self.slam.reported_path()
        keep = decimation(len(stamps), self.settings["path_max_poses"])
        if keep is not None:
            stamps, poses = stamps[keep], poses[keep]
        self._publish(self._path_pub, self._path_builder.build(self._header(), stamps, poses))

    def _publish_particles(self) -> None:
        self._publish(self._particles_pub,
                      self._particles_message(self._header(), self.slam.particle_poses()))

    def _particles_message(self, header: Header, poses: np.ndarray) -> PoseArray:
        """The ``~/particles`` message of the particles' planar poses."""
        return ros_io.pose_array(header, poses)

    def _publish_map(self) -> None:
        """~/landmarks markers (DELETE for landmarks gone or unconfirmed since the last time) and
        ~/map_cloud: the confirmed landmarks only (existence >= map_min_existence), of the
        smoother's latest solve when ``smoothing_period`` is on (the frame of ~/pose)."""
        landmark_map = self.slam.reported_map()
        keys = set(landmark_map.keys.tolist())
        header = self._header()
        removed = sorted(self._published_keys - keys)
        self._publish(self._markers_pub, self._marker_builder.build(header, landmark_map, removed))
        self._publish(self._map_cloud_pub, ros_io.map_cloud(header, landmark_map))
        self._published_keys = keys
        self._map_dirty = False

    def _diagnostic_state(self) -> list[KeyValue]:
        return [KeyValue(key="queued_observations", value=str(len(self._pending)))]

    # --- services ------------------------------------------------------------------------------

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
            response.message = self.save_map(map_file)
            response.success = True
        except Exception as error:  # noqa: BLE001 - report the failure to the caller
            response.success, response.message = False, f"cannot write '{map_file}': {error}"
        return response

    def save_map(self, map_file: str | PathLike, overwrite: bool | None = None,
                 inputs: Sequence[str | PathLike] = ()) -> str:
        """Write the best particle's confirmed map, refined by the least squares over its path
        (``map_refinement``; the filter's map, logged, when that fails; in localization the
        fixed map); returns what was written. ``overwrite`` (default: ``save_map_overwrite``)
        lets it replace an existing file, never one of ``inputs`` (``fastslam_ros.output``);
        OSError when the file cannot be written."""
        if overwrite is None:
            overwrite = bool(self.settings["save_map_overwrite"])
        check_output(map_file, overwrite, "file", inputs)  # before the refinement's work
        landmark_map = self.slam.best_map(self.config.map_min_existence)
        what = "the loaded map (localization)"
        if self.config.mode == "mapping":
            try:
                landmark_map, report = refine_best_map(self.slam)
                what = (f"refined by least squares over {report.readings} readings, "
                        f"{report.associated} of {report.observations} observations, "
                        f"{report.refined} landmarks moved {report.mean_shift:.3f} m on average, "
                        f"in {report.seconds:.2f} s")
            except Exception as error:  # noqa: BLE001 - the filter's map is still worth saving
                self.get_logger().warning(f"map refinement failed ({error}); saving the "
                                          "filter's map")
                what = f"the filter's map: refinement failed ({error})"
        written = map_files.write_map_file(map_file, landmark_map, self.settings["map_frame"],
                                        self._last_update_stamp, overwrite, inputs)
        message = f"{len(landmark_map.keys)} landmarks written to {written}, {what}"
        self.get_logger().info(message)
        return message

    def _load_map(self, map_file: str) -> int:
        """Seed every particle's map from a map file (map_files.MapFileError when unreadable);
        returns the number of landmarks."""
        loaded = map_files.read_map_file(map_file)
        frame = self.settings["map_frame"]
        if loaded.frame_id and loaded.frame_id != frame:
            raise map_files.MapFileError(f"map file '{map_file}': its frame '{loaded.frame_id}' "
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


def read_params_file(path: str | PathLike, node_name: str = f"/{NODE_NAME}") -> dict[str, object]:
    """``node_console.read_params_file``, for this node unless ``node_name`` says otherwise."""
    return node_console.read_params_file(path, node_name)


USAGE = """FastSLAM landmark SLAM node: nav_msgs/Odometry on odom and sensor_msgs/PointCloud2 on
landmarks in; pose, path, map markers, map cloud, particles and map -> odom out (docs/node.md).

ROS arguments follow --ros-args, as for every ROS 2 node:
  fastslam_node --ros-args --params-file config/fastslam.yaml -p num_particles:=200 \\
      -r odom:=/wheel/odom -r landmarks:=/detector/landmarks -p use_sim_time:=true
Every parameter, its default and range: docs/parameters.md."""



def main(args: list[str] | None = None) -> int:
    """Console entry point ``fastslam_node``; exit status 1 on a bad parameter or file."""
    return run_node("fastslam_node", NODE_NAME, USAGE, FastSLAMNode, args)


if __name__ == "__main__":
    sys.exit(main())
