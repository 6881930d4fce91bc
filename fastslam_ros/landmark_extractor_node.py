# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""ROS 2 node around the landmark extractor: laser scans in, point landmarks out.

Node ``landmark_extractor`` (console script ``landmark_extractor_node``). Each
``sensor_msgs/LaserScan`` on ``scan`` (intensities used when present; REP 117 meanings of inf
and NaN) becomes a ``landmarks`` cloud (``sensor_msgs/PointCloud2`` in the scan's frame, with
the scan's exact header: x y z float32, id int32 = -1, radius and intensity float32) that
``fastslam_node`` reads as it is, and ``~/markers`` for RViz (throttled). Parameters (the
extractor's, see ``fastslam_ros.extractor.ExtractorSettings``, fixed at start; the node's
frame and marker rate), the stamp and frame gates, the counters and ``/diagnostics`` are the
other nodes' (``node_base.FilterNode``).

With ``deskew_scans`` (default) or ``static_window`` > 0 the node also reads
``nav_msgs/Odometry`` on ``odom``, and a scan waits, like the SLAM node's clouds, for odometry
covering its stamp (and its sweep). ``deskew_scans``: a scan swept while the robot moved
(``time_increment`` > 0) has its landmarks brought back to where the laser was at the first
beam, the stamp's pose (``core.sweep``), at the odometry's motion over the sweep (since the
previous scan when the odometry does not reach the sweep's end in time); without that motion
(no odometry yet, none covering the stamp in ``max_observation_wait``, the previous scan too
long ago, a sweep longer than the scan period allows) they are published as seen and counted
(``scans_not_deskewed``).
``static_window``: the landmarks that ``extractor.static_filter`` finds moved (where an
earlier scan saw free space, or displaced: walking people) are not published; a scan with no
odometry pose at its stamp is dropped and counted (``dropped_stale``). See docs/extractor.md.
"""
from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass

import numpy as np
from diagnostic_msgs.msg import KeyValue
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan, PointCloud2
from std_msgs.msg import Header
from visualization_msgs.msg import MarkerArray

from fastslam_ros import extractor_io
from fastslam_ros.core.geometry import compose
from fastslam_ros.core.params import check_fields, parameter, specs
from fastslam_ros.extractor import Extraction, ExtractorSettings, RawScan, extract_landmarks
from fastslam_ros.extractor.extract import REJECTIONS
from fastslam_ros.extractor.static_filter import StaticFilter
from fastslam_ros.node_base import INPUT_QOS, STREAM_QOS, FilterNode
from fastslam_ros.node_console import run_node
from fastslam_ros.node_diagnostics import DIAGNOSTICS_PERIOD
from fastslam_ros.node_parameters import max_speed_parameter, max_yaw_rate_parameter

NODE_NAME = "landmark_extractor"
COUNTERS = (
    "received_scan", "used_scan", "scan_missing", "resets", "time_jumps", "landmarks",
    "reflectors", *(f"rejected_{reason}" for reason in REJECTIONS), "rejected_moving",
    "dropped_malformed_scan", "dropped_oversized_scan", "dropped_wrong_frame",
    "dropped_invalid_stamp", "dropped_outlier_stamp", "dropped_duplicate_stamp",
    "dropped_internal_error", "scans_not_deskewed",
)
THROTTLED_OUTPUTS = ("markers_rate",)
DIAGNOSED = (("time_jumps", "time jumps"), ("scans_not_deskewed", "swept scans not deskewed"))
"""Counters whose growth /diagnostics reports (after drops, lost messages, silence and lag)."""


@dataclass(frozen=True)
class NodeSettings:
    """The ROS side of the node: the scan frame, the marker rate and, for static_window,
    the odometry's frames, wait and plausibility gates."""

    scan_frame: str = parameter("", "Frame the scans must be in; '': the first scan's frame.")
    max_beams_per_scan: int = parameter(
        8192, "A scan with more beams is dropped unread (dropped_oversized_scan): no 2-D "
              "laser sends that many in one scan; such a message is a broken driver's.",
        low=1, high=1_000_000)
    markers_rate: float = parameter(5.0, "Maximum rate of ~/markers (Hz; 0: never).",
                                    low=0.0, high=1000.0)
    odom_frame: str = parameter("odom", "With deskew_scans or static_window: odometry frame "
                                        "(REP 105); '' accepts any.")
    base_frame: str = parameter("base_link", "With deskew_scans or static_window: odometry's "
                                             "child_frame_id; '' accepts any.")
    max_observation_wait: float = parameter(
        0.5, "With deskew_scans or static_window: how long (s of node time) a scan waits for "
             "odometry that covers its stamp (and its sweep, with deskew_scans); after that it "
             "is dropped (dropped_stale) or, deskew_scans only, published as seen "
             "(scans_not_deskewed; at the motion since the previous scan when only the sweep "
             "is not covered).",
        low=0.0, high=60.0)
    max_speed: float = max_speed_parameter()
    max_yaw_rate: float = max_yaw_rate_parameter()

    def validate(self) -> "NodeSettings":
        """Raise ``ParameterValueError`` naming the bad setting; return self when all are good."""
        check_fields(self)
        return self


CORE_PARAMETERS = specs(ExtractorSettings)
"""{name: (default, spec)} of the extractor's parameters, fixed at start."""
NODE_PARAMETERS = specs(NodeSettings)
"""{name: (default, spec)} of the ROS-side parameters, which may change at runtime."""


def parameter_specs() -> dict:
    """{name: (default, spec)} of every parameter of the node, extractor first."""
    return {**CORE_PARAMETERS, **NODE_PARAMETERS}


@dataclass
class PendingScan:
    """A scan's extraction waiting for the odometry that covers its stamp (and its sweep, to
    be deskewed)."""

    stamp: float
    arrival: float
    header: Header
    extraction: Extraction
    scan: RawScan
    odometry_until: float


class LandmarkExtractorNode(FilterNode):
    """``scan`` in, ``landmarks`` and ``~/markers`` out, one cloud per usable scan."""

    NODE_NAME = NODE_NAME

    def _set_up(self) -> None:
        self._start_inputs(COUNTERS, "scan", "scan", "dropped_stale", THROTTLED_OUTPUTS,
                           DIAGNOSED, odometry=False)
        self.extractor_settings = self._declare_parameters(
            CORE_PARAMETERS, lambda **values: ExtractorSettings(**values).validate(),
            NODE_PARAMETERS, NodeSettings)
        s = self.extractor_settings
        self.static_filter: StaticFilter | None = None
        """The moving-object filter (static_window > 0), which needs odometry."""
        if s.static_window > 0.0:
            self.static_filter = StaticFilter(s.static_window, s.static_tolerance,
                                              s.static_heading_tolerance)
        self.reads_odometry = s.deskew_scans or self.static_filter is not None
        if self.static_filter is None:     # a scan whose odometry is late is published as seen
            self._stale_counter = "scans_not_deskewed"
        self._sensor = np.array([s.sensor_x, s.sensor_y, s.sensor_yaw])
        self._sweeping = False
        """Whether the last scan was swept (time_increment > 0)."""
        if self.reads_odometry:
            self._start_odometry(map_to_odom=False)
            self.create_subscription(Odometry, "odom", self.on_odometry, INPUT_QOS)
        self._last: tuple[Header, Extraction] | None = None
        self._no_intensities = False
        self._landmarks_pub = self.create_publisher(PointCloud2, "landmarks", STREAM_QOS)
        self._markers_pub = self.create_publisher(MarkerArray, "~/markers", STREAM_QOS)
        self.create_subscription(LaserScan, "scan", self.on_scan, INPUT_QOS)
        self.create_timer(DIAGNOSTICS_PERIOD, self._on_timer)
        self.get_logger().info(f"landmark extractor: detector {s.detector}, ranges "
                               f"[{s.min_range}, {s.max_range}) m" + (
                                   f", static over {s.static_window} s" if self.static_filter
                                   else "") + (", deskewed" if s.deskew_scans else "") + (
                                   " (odometry on odom)" if self.reads_odometry else ""))

    def on_scan(self, msg: LaserScan) -> None:
        """Subscription callback: extract the scan's landmarks and publish them."""
        self.stats["received_scan"] += 1
        self._run_callback("scan", self._handle_scan, msg)

    def _handle_scan(self, msg: LaserScan) -> None:
        read = self._read_scan(msg, extractor_io.read_scan, self.settings["max_beams_per_scan"])
        if read is None:
            return
        scan, stamp, now = read
        extraction = extract_landmarks(scan, self.extractor_settings)
        self._no_intensities = len(scan.intensities) == 0
        self.stats["used_scan"] += 1
        for reason, count in extraction.rejected.items():
            self.stats[f"rejected_{reason}"] += count
        header = Header(stamp=msg.header.stamp, frame_id=msg.header.frame_id)
        self._sweeping = scan.time_increment != 0.0
        if self.static_filter is not None or (self._deskews(scan)
                                              and self._odometry.latest_stamp is not None):
            until = self._odometry_until(stamp, scan.time_increment, len(scan.ranges),
                                         self._deskews(scan))
            return self._queue(PendingScan(stamp, now, header, extraction, scan, until), now)
        self.stats["scans_not_deskewed"] += self._deskews(scan)   # no odometry yet
        self._last_reading_stamp = stamp
        self._publish_landmarks(stamp, header, extraction)
        self._publish_throttled(now)

    def _deskews(self, scan: RawScan) -> bool:
        """Whether ``scan`` is to be deskewed (swept, and deskew_scans)."""
        return self.extractor_settings.deskew_scans and scan.time_increment != 0.0

    def _publish_landmarks(self, stamp: float, header: Header, extraction: Extraction) -> None:
        """The ``landmarks`` cloud of one scan, counted."""
        self.stats["landmarks"] += len(extraction.landmarks)
        self.stats["reflectors"] += int(extraction.landmarks.reflector.sum())
        self._publish(self._landmarks_pub,
                      extractor_io.landmark_cloud(header, extraction.landmarks))
        self._last = (header, extraction)
        self._note_lag(stamp)

    def _update(self, pending: "PendingScan") -> None:
        """A queued scan: its landmarks deskewed and, with the static filter, but those that
        moved, at the odometry pose of its stamp. Without such a pose the static filter drops
        the scan (dropped_stale); deskewing alone publishes it as seen."""
        self._last_reading_stamp = pending.stamp
        covered = self._odometry.covers(pending.stamp)     # if not, counted by _process_ready
        late = covered and pending.stamp < self._odometry.anchor_stamp
        if self.static_filter is None and (late or not covered):
            self.stats["scans_not_deskewed"] += late
            return self._publish_landmarks(pending.stamp, pending.header, pending.extraction)
        if not covered:
            return self._warn("dropped_stale", f"scan dropped: no odometry covered its stamp "
                                               f"{pending.stamp:.3f} in max_observation_wait "
                                               "[dropped_stale]")
        if late:
            return self._drop("stale", f"scan dropped: stamped {pending.stamp:.3f}, before the "
                                       f"odometry kept ({self._odometry.anchor_stamp:.3f})")
        self._odometry.advance(pending.stamp)
        scan = pending.scan
        motion = self._sweep_motion(pending.stamp, scan.time_increment, len(scan.ranges),
                                    self._sensor, self.extractor_settings.deskew_scans)
        landmarks = pending.extraction.landmarks.at_first_beam(*motion)
        if self.static_filter is not None:
            keep = self.static_filter.update(pending.stamp,
                                             compose(self._odometry.anchor_pose, self._sensor),
                                             landmarks.x, landmarks.y, pending.scan, motion)
            self.stats["rejected_moving"] += int(np.count_nonzero(~keep))
            landmarks = landmarks.subset(keep)
        self._publish_landmarks(pending.stamp, pending.header,
                                dataclasses.replace(pending.extraction, landmarks=landmarks))

    def _predict(self, pose_from: np.ndarray, pose_to: np.ndarray) -> None:
        """Nothing to move: the extractor keeps odometry only for the scans' poses."""

    def reset(self) -> None:
        """Forget the input time (a looped bag), the odometry and the static filter's scans."""
        self._reset_inputs()
        if self.static_filter is not None:
            self.static_filter.clear()

    def flush(self) -> None:
        """Run the queued scans, publish the markers of the last scan and the diagnostics now
        (end of a bag)."""
        if self.reads_odometry:
            self._process_ready(self._now(), force=True)
        if self._last is not None and self._throttles["markers_rate"].rate > 0.0:
            self._publish_markers()
        self._publish_diagnostics("extractor")

    def _publish_markers(self) -> None:
        header, extraction = self._last
        self._publish(self._markers_pub,
                      extractor_io.landmark_markers(header, extraction.landmarks))

    def _publish_throttled(self, now: float) -> None:
        if self._last is not None and self._throttles["markers_rate"].due(now):
            self._publish_markers()
        if self._diagnostics_throttle.due(now):
            self._publish_diagnostics("extractor")

    def _diagnostic_state(self) -> list[KeyValue]:
        if self._last is None:
            return []
        extraction = self._last[1]
        return [KeyValue(key="last_scan_landmarks", value=str(len(extraction.landmarks))),
                KeyValue(key="last_scan_segments", value=str(extraction.segments)),
                KeyValue(key="last_scan_reflector_threshold",
                         value=f"{extraction.threshold:.6g}")]

    def _standing_problems(self) -> list[str]:
        if self.stats["used_scan"] == 0:
            return ["waiting for a usable scan"]
        problems = []
        if self._no_intensities and self.extractor_settings.detector != "circles":
            problems.append(f"detector '{self.extractor_settings.detector}' needs intensities; "
                            "the scans carry none (no reflectors can be found)")
        if (self.extractor_settings.deskew_scans and self._sweeping
                and self._odometry.latest_stamp is None):
            problems.append("the scans are swept (time_increment > 0) but no odometry has "
                            "arrived on odom: landmarks are not deskewed (deskew_scans)")
        return problems


USAGE = """Landmark extractor: sensor_msgs/LaserScan on scan in; point landmarks (poles, trunks,
reflectors) on landmarks (PointCloud2 for fastslam_node) and ~/markers out (docs/extractor.md).

ROS arguments follow --ros-args, as for every ROS 2 node:
  landmark_extractor_node --ros-args --params-file config/landmark_extractor.yaml \\
      -r scan:=/base_scan"""


def main(args: list[str] | None = None) -> int:
    """Console entry point ``landmark_extractor_node``; exit status 1 on a bad parameter."""
    return run_node("landmark_extractor_node", NODE_NAME, USAGE, LandmarkExtractorNode, args)


if __name__ == "__main__":
    sys.exit(main())
