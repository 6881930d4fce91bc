# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""ROS 2 node around the people tracker: map, scans and odometry in; robot pose and people out.

Node ``people_tracker`` (console script ``people_tracker_node``). The map comes from ``map``
(``nav_msgs/OccupancyGrid``, transient local, as nav2's map_server publishes) or from the
``map_file`` parameter (a nav2 map YAML). Scans wait, like the SLAM node's clouds, for the
odometry that covers their stamp and are used at the robot pose interpolated there
(node_support.timing). ``initialpose`` (RViz's "2D Pose Estimate") places the robot; without it the
tracker localizes globally over the free space. Parameters, bad-input gates (frames, stamps,
time going backwards, implausible odometry) and ``/diagnostics`` are the SLAM node's
(``node_base.FilterNode``): bad input is counted, warned about (throttled) and dropped.
The people tracker's own gates: maps and scans beyond their size caps, scans whose geometry
does not hold (angle_max, range limits) or in another frame than the first scan's, maps with
no free cell, initial poses off the map. A map sent again changes nothing; a changed one keeps
the pose (people.lifecycle); a lost tracker localizes globally again. Every output of a scan
carries the scan's exact ``header.stamp``. See docs/people.md.
"""
from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import KeyValue
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from sensor_msgs.msg import LaserScan, PointCloud2
from std_msgs.msg import Header
from visualization_msgs.msg import MarkerArray

from fastslam_ros import people_io, ros_io
from fastslam_ros.core.params import ParameterValueError, check_fields, parameter, specs
from fastslam_ros.core.sweep import STILL
from fastslam_ros.node_base import INPUT_QOS, LATEST_QOS, MAP_QOS, STREAM_QOS, FilterNode
from fastslam_ros.node_console import run_node
from fastslam_ros.node_diagnostics import DIAGNOSTICS_PERIOD
from fastslam_ros.node_parameters import (ParameterError, max_speed_parameter,
                                          max_yaw_rate_parameter)
from fastslam_ros.people import PeopleTracker, Scan, TrackerSettings
from fastslam_ros.people.detection import deskewed
from fastslam_ros.people.lifecycle import (LostWatch, change_map, initial_pose_problem,
                                           repair, same_map)

NODE_NAME = "people_tracker"
POSE_ESTIMATES = ("best", "mean")
COUNTERS = (
    "received_map", "received_scan", "received_odom", "received_initialpose",
    "used_map", "used_scan", "used_odom", "used_initialpose",
    "late_scans", "stale_scans", "resets", "time_jumps", "odometry_jumps",
    "odom_missing", "scan_missing",
    "people_created", "people_removed", "global_localizations", "converged",
    "repeated_maps", "map_changes", "lost", "filter_recoveries",
    "dropped_malformed_map", "dropped_oversized_map", "dropped_malformed_scan",
    "dropped_oversized_scan", "dropped_wrong_frame", "dropped_initialpose_off_map",
    "dropped_initialpose_covariance",
    "dropped_invalid_quaternion", "dropped_nan", "dropped_implausible_odometry",
    "dropped_invalid_stamp", "dropped_outlier_stamp", "dropped_duplicate_stamp",
    "dropped_time_backwards", "dropped_stale", "dropped_no_map", "dropped_internal_error",
    "scans_not_deskewed",
)
THROTTLED_OUTPUTS = ("particles_rate", "markers_rate")
DIAGNOSED = (("late_scans", "scans older than the filter's time"),
             ("stale_scans", "scans used without their odometry"),
             ("odometry_jumps", "odometry jumps bridged"),
             ("time_jumps", "time jumps"),
             ("map_changes", "changed map(s) installed"),
             ("lost", "times lost (localizing globally again)"),
             ("filter_recoveries", "filter state repaired"),
             ("scans_not_deskewed", "swept scans not deskewed"))
"""Counters whose growth /diagnostics reports (after drops, lost messages, silence and lag)."""


@dataclass(frozen=True)
class NodeSettings:
    """The ROS side of the node: frames, map source, output rates."""

    map_frame: str = parameter("map", "Frame of the map, the pose, the particles and the people. "
                                      "Not empty.")
    odom_frame: str = parameter("odom", "Odometry frame (REP 105); '' accepts any.")
    base_frame: str = parameter("base_link", "Robot frame: odometry's child_frame_id; '' "
                                             "accepts any.")
    scan_frame: str = parameter("", "Frame the scans must be in; '': the first scan's frame.")
    map_file: str = parameter("", "nav2 map YAML to load at start; '': subscribe to 'map'.")
    pose_estimate: str = parameter("mean", "~/pose is the weighted 'mean' of the robot "
                                           "particles or the 'best' one.", choices=POSE_ESTIMATES)
    particles_rate: float = parameter(2.0, "Maximum rate of ~/particles (Hz; 0: never).",
                                      low=0.0, high=1000.0)
    markers_rate: float = parameter(5.0, "Maximum rate of ~/people_markers (Hz; 0: never).",
                                    low=0.0, high=1000.0)
    max_observation_wait: float = parameter(
        0.5, "How long (s) a scan waits for odometry covering its stamp (and its sweep, with "
             "deskew_scans).", low=0.0, high=60.0)
    deskew_scans: bool = parameter(
        True, "Correct each scan for the robot's motion while the laser swept it (its "
              "time_increment, the odometry's turn rate and velocity over the sweep, or since "
              "the previous scan when it does not cover the sweep in max_observation_wait); "
              "false for a driver whose time_increment is wrong.")
    publish_tf: bool = parameter(True, "Broadcast map -> odom on /tf (when tf2_ros is "
                                       "installed).")
    max_speed: float = max_speed_parameter()
    max_yaw_rate: float = max_yaw_rate_parameter()

    def validate(self) -> "NodeSettings":
        """Raise ``ParameterValueError`` naming the bad setting; return self when all are good."""
        check_fields(self)
        if not self.map_frame:
            raise ParameterValueError("map_frame", "must not be empty")
        return self


CORE_PARAMETERS = specs(TrackerSettings)
"""{name: (default, spec)} of the tracker's parameters, fixed at start."""
NODE_PARAMETERS = specs(NodeSettings)
"""{name: (default, spec)} of the ROS-side parameters, which may change at runtime (except
START_ONLY_PARAMETERS)."""
START_ONLY_PARAMETERS = ("map_file",)
"""ROS-side parameters read once at start: a runtime change is refused."""


def parameter_specs() -> dict:
    """{name: (default, spec)} of every parameter of the node, tracker first."""
    return {**CORE_PARAMETERS, **NODE_PARAMETERS}


@dataclass
class PendingScan:
    """A scan waiting for odometry that covers its stamp (and its sweep, to be deskewed)."""

    stamp: float
    scan: Scan
    arrival: float
    exact: tuple[int, int]
    """The scan's header.stamp (sec, nanosec), which every output of the scan carries."""
    odometry_until: float


class PeopleTrackerNode(FilterNode):
    """The conditional particle filter on ``map`` + ``scan`` + ``odom``."""

    NODE_NAME = NODE_NAME

    def _set_up(self) -> None:
        self._start_inputs(COUNTERS, "scan", "scan", "stale_scans", THROTTLED_OUTPUTS, DIAGNOSED)
        self.tracker_settings = self._declare_parameters(
            CORE_PARAMETERS, lambda **values: TrackerSettings(**values).validate(),
            NODE_PARAMETERS, NodeSettings, START_ONLY_PARAMETERS)
        self.tracker = PeopleTracker(self.tracker_settings)
        self._initial: tuple[np.ndarray, np.ndarray] | None = None
        self._published_keys: set[int] = set()
        self._lost_watch = LostWatch()
        self._relocalizing = False
        self._last_exact: tuple[int, int] = (0, 0)
        self._exact_header: tuple[Any, Header | None] = (None, None)

        self._pose_pub = self.create_publisher(PoseWithCovarianceStamped, "~/pose", STREAM_QOS)
        self._particles_pub = self.create_publisher(PoseArray, "~/particles", LATEST_QOS)
        self._people_pub = self.create_publisher(PointCloud2, "~/people", STREAM_QOS)
        self._markers_pub = self.create_publisher(MarkerArray, "~/people_markers", STREAM_QOS)
        map_file = self.settings["map_file"]
        if map_file:
            s = self.tracker_settings
            try:
                grid = people_io.load_map_file(map_file, s.likelihood_max_distance,
                                               s.max_map_cells)
            except (people_io.MalformedMapError, ros_io.OversizedError) as error:
                raise ParameterError(f"parameter 'map_file': {error}") from None
            self._use_map(grid)
        else:
            self.create_subscription(OccupancyGrid, "map", self.on_map, MAP_QOS)
        self.create_subscription(LaserScan, "scan", self.on_scan, INPUT_QOS)
        self.create_subscription(Odometry, "odom", self.on_odometry, INPUT_QOS)
        self.create_subscription(PoseWithCovarianceStamped, "initialpose", self.on_initial_pose,
                                 LATEST_QOS)
        self.create_timer(DIAGNOSTICS_PERIOD, self._on_timer)
        s = self.tracker_settings
        self.get_logger().info(
            f"people tracker: {s.num_particles} robot particles ({s.global_particles} while "
            f"localizing globally) x {s.max_people} people x {s.people_particles}; map "
            f"{'file ' + map_file if map_file else 'topic'}")

    # --- inputs --------------------------------------------------------------------------------

    def on_map(self, msg: OccupancyGrid) -> None:
        self.stats["received_map"] += 1
        self._run_callback("map", self._handle_map, msg)

    def on_scan(self, msg: LaserScan) -> None:
        self.stats["received_scan"] += 1
        self._run_callback("scan", self._handle_scan, msg)

    def on_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        self.stats["received_initialpose"] += 1
        self._run_callback("initialpose", self._handle_initial_pose, msg)

    def _handle_map(self, msg: OccupancyGrid) -> None:
        """Validate a map before it replaces the current one: the same map again is a no-op,
        a changed one keeps the pose estimate (``lifecycle.change_map``)."""
        if not self._frame_ok("map_frame", msg.header.frame_id, "map"):
            return
        s = self.tracker_settings
        try:
            grid = people_io.read_occupancy_grid(msg, s.likelihood_max_distance,
                                                 s.max_map_cells)
        except ros_io.OversizedError as error:
            return self._drop("oversized_map", f"map dropped: {error}")
        except (people_io.MalformedMapError, ros_io.InvalidQuaternionError) as error:
            return self._drop("malformed_map", f"map dropped: {error}")
        if same_map(self.tracker.grid, grid):
            self.stats["repeated_maps"] += 1
            return
        if self.tracker.grid is None:
            return self._use_map(grid)
        change = change_map(self.tracker, grid)
        self.stats["used_map"] += 1
        self.stats["map_changes"] += 1
        self.stats["people_removed"] += change.people_removed
        self._lost_watch.clear()
        if not change.kept_pose:
            self.stats["global_localizations"] += 1
            self._warn("map_changes", "changed map: localizing globally on it (no pose "
                                      "yet, or no robot particle in its free space)")

    def _use_map(self, grid) -> None:
        """The first usable map: the filter starts on it."""
        self.tracker.set_map(grid)
        self.stats["used_map"] += 1
        self._start_filter()

    def _start_filter(self) -> None:
        """(Re)start the particles: at the initial pose if one was given (and fits the
        map), else globally."""
        self._lost_watch.clear()
        self._relocalizing = False
        if self._initial is not None and self._initial_pose_fits(*self._initial):
            self.tracker.reset(*self._initial)
        else:
            self._initial = None
            self.tracker.reset()
            self.stats["global_localizations"] += 1

    def _initial_pose_fits(self, pose: np.ndarray, covariance: np.ndarray) -> bool:
        """Whether an initial pose can place the robot on the map (counted when not)."""
        problem = initial_pose_problem(self.tracker.grid, pose, covariance)
        if problem is not None:
            self._drop(problem[0], f"{problem[1]}: dropped")
        return problem is None

    def _handle_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        given = self._initial_pose_input(msg)
        if given is None:
            return
        if self.tracker.grid is not None and not self._initial_pose_fits(*given):
            return
        self._initial = given
        self.stats["used_initialpose"] += 1
        if self.tracker.grid is not None:
            self._lost_watch.clear()
            self._relocalizing = False
            self.tracker.reset(*self._initial)

    def _handle_scan(self, msg: LaserScan) -> None:
        read = self._read_scan(msg, people_io.read_scan,
                               self.tracker_settings.max_beams_per_scan)
        if read is None:
            return
        scan, stamp, now = read
        exact = (int(msg.header.stamp.sec), int(msg.header.stamp.nanosec))
        until = self._odometry_until(stamp, scan.time_increment, len(scan.ranges),
                                     self.settings["deskew_scans"])
        self._queue(PendingScan(stamp, scan, now, exact, until), now)

    # --- filter --------------------------------------------------------------------------------

    def _predict(self, pose_from: np.ndarray, pose_to: np.ndarray) -> None:
        self.tracker.predict(pose_from, pose_to)

    def _update(self, pending: PendingScan) -> None:
        if not self.tracker.ready:
            return self._drop("no_map", "scan dropped: no map yet")
        self._predict_to(pending.stamp, "late_scans")
        scan = self._deskewed(pending)
        self._repaired()
        localizing = self.tracker.globally_localizing
        try:
            report = self.tracker.update(pending.stamp, scan)
        except (ValueError, ArithmeticError, IndexError) as error:
            if not self._repaired():  # not a broken state: a real bug, reported as such
                raise
            return self._drop("internal_error", f"update failed on a non-finite filter state "
                                                f"({error!r}): repaired, scan lost")
        self._repaired()
        self._note_lag(pending.stamp)
        if localizing and report.converged:
            self.stats["converged"] += 1
            self._relocalizing = False
        self.stats["used_scan"] += 1
        self.stats["people_created"] += report.created
        self.stats["people_removed"] += report.removed
        self._last_reading_stamp = pending.stamp
        self._last_exact = pending.exact
        self._publish_estimate()
        if self._lost_watch.lost(self.tracker, scan):
            self._relocalize()

    def _deskewed(self, pending: PendingScan) -> Scan:
        """The scan as taken all at once at its stamp (``detection.deskewed``), at the
        odometry's turn rate and velocity over its sweep (``FilterNode._sweep_motion``); else
        as it is."""
        scan = pending.scan
        motion = self._sweep_motion(pending.stamp, scan.time_increment, len(scan.ranges),
                                    self.tracker.offset, self.settings["deskew_scans"])
        return scan if motion == STILL else deskewed(scan, *motion)

    def _repaired(self) -> bool:
        """Self-check before and after an update: repair a non-finite state (counted,
        warned)."""
        if not repair(self.tracker):
            return False
        self.stats["filter_recoveries"] += 1
        self._warn("filter_recoveries", "the filter's state was not finite: "
                   "repaired from the finite particles (or localizing globally) "
                   "[filter_recoveries]")
        return True

    def _relocalize(self) -> None:
        """The tracker is lost: forget the pose and the people, localize globally."""
        self.stats["lost"] += 1
        self.stats["global_localizations"] += 1
        self._warn("lost", "lost: the scans do not fit the map at the estimated pose; "
                           "localizing globally [lost]")
        self._lost_watch.clear()
        self._relocalizing = True
        self.tracker.reset()

    def reset(self) -> None:
        """Forget odometry, queued scans and people; keep the map and restart the particles."""
        self._reset_inputs()
        if self.tracker.grid is not None:
            self._start_filter()

    def flush(self) -> None:
        """Run every queued scan now (end of a bag) and publish the throttled outputs once."""
        self._process_ready(self._now(), force=True)
        if self.stats["used_scan"]:
            if self._throttles["particles_rate"].rate > 0.0:
                self._publish_particles()
            if self._throttles["markers_rate"].rate > 0.0:
                self._publish_markers()
        self._publish_diagnostics("tracker")

    # --- outputs -------------------------------------------------------------------------------

    def _scan_header(self) -> Header:
        """The map-frame header of the last scan's outputs: its exact stamp (sec, nanosec,
        never through float seconds); one object for every output of that scan."""
        key = (self._last_exact, self.settings["map_frame"])
        if self._exact_header[0] != key:
            sec, nanosec = self._last_exact
            self._exact_header = (key, Header(stamp=Time(sec=sec, nanosec=nanosec),
                                              frame_id=key[1]))
        return self._exact_header[1]

    def _publish_estimate(self) -> None:
        """~/pose, ~/people and map -> odom at the scan's exact stamp."""
        header = self._scan_header()
        mean, covariance = self.tracker.mean_pose_and_covariance()
        pose = mean if self.settings["pose_estimate"] == "mean" else self.tracker.best_pose()
        self._publish(self._pose_pub, self._pose_message(header, pose, covariance))
        self._publish(self._people_pub,
                      people_io.people_cloud(header, self.tracker.published_people()))
        self._publish_map_to_odom(header, pose)

    def _publish_throttled(self, now: float) -> None:
        if self.stats["used_scan"]:
            if self._throttles["particles_rate"].due(now):
                self._publish_particles()
            if self._throttles["markers_rate"].due(now):
                self._publish_markers()
        if self._diagnostics_throttle.due(now):
            self._publish_diagnostics("tracker")

    def _publish_particles(self) -> None:
        self._publish(self._particles_pub,
                      ros_io.pose_array(self._scan_header(), self.tracker.poses))

    def _publish_markers(self) -> None:
        people = self.tracker.published_people()
        keys = set(people.keys.tolist())
        removed = sorted(self._published_keys - keys)
        self._publish(self._markers_pub,
                      people_io.people_markers(self._scan_header(), people, removed))
        self._published_keys = keys

    def _diagnostic_state(self) -> list[KeyValue]:
        tracker = self.tracker
        state = [KeyValue(key="queued_scans", value=str(len(self._pending))),
                 KeyValue(key="robot_particles", value=str(tracker.num_particles)),
                 KeyValue(key="localizing_globally", value=str(tracker.globally_localizing)),
                 KeyValue(key="map_received", value=str(tracker.grid is not None))]
        if tracker.ready:
            state.append(KeyValue(key="people", value=str(len(tracker.published_people().keys))))
        monitor = tracker.mixed_pixels
        state += [KeyValue(key="mixed_pixel_edges", value=f"{monitor.bridged}/{monitor.edges}"),
                  KeyValue(key="mixed_pixel_filtering", value=str(monitor.filtering))]
        return state

    def _standing_problems(self) -> list[str]:
        if self.tracker.grid is None:
            dropped = self.stats["dropped_malformed_map"] + self.stats["dropped_oversized_map"]
            return [f"waiting for a usable map ({dropped} dropped)" if dropped
                    else "waiting for a usable map"]
        if self._relocalizing:
            return ["lost: localizing globally again"]
        return []


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
