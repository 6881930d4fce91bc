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
other nodes' (``node_base.FilterNode``, without odometry). See docs/extractor.md.
"""
from __future__ import annotations

import sys
from dataclasses import dataclass

from diagnostic_msgs.msg import KeyValue
from sensor_msgs.msg import LaserScan, PointCloud2
from std_msgs.msg import Header
from visualization_msgs.msg import MarkerArray

from fastslam_ros import extractor_io
from fastslam_ros.core.params import check_fields, parameter, specs
from fastslam_ros.extractor import Extraction, ExtractorSettings, extract_landmarks
from fastslam_ros.extractor.extract import REJECTIONS
from fastslam_ros.node_base import INPUT_QOS, STREAM_QOS, FilterNode
from fastslam_ros.node_console import run_node
from fastslam_ros.node_diagnostics import DIAGNOSTICS_PERIOD

NODE_NAME = "landmark_extractor"
COUNTERS = (
    "received_scan", "used_scan", "scan_missing", "resets", "time_jumps", "landmarks",
    "reflectors", *(f"rejected_{reason}" for reason in REJECTIONS),
    "dropped_malformed_scan", "dropped_wrong_frame", "dropped_invalid_stamp",
    "dropped_outlier_stamp", "dropped_duplicate_stamp", "dropped_internal_error",
)
THROTTLED_OUTPUTS = ("markers_rate",)
DIAGNOSED = (("time_jumps", "time jumps"),)
"""Counters whose growth /diagnostics reports (after drops, lost messages, silence and lag)."""


@dataclass(frozen=True)
class NodeSettings:
    """The ROS side of the node: the scan frame and the marker rate."""

    scan_frame: str = parameter("", "Frame the scans must be in; '' accepts any.")
    markers_rate: float = parameter(5.0, "Maximum rate of ~/markers (Hz; 0: never).",
                                    low=0.0, high=1000.0)

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


class LandmarkExtractorNode(FilterNode):
    """``scan`` in, ``landmarks`` and ``~/markers`` out, one cloud per usable scan."""

    NODE_NAME = NODE_NAME

    def _set_up(self) -> None:
        self._start_inputs(COUNTERS, "scan", "scan", "", THROTTLED_OUTPUTS, DIAGNOSED,
                           odometry=False)
        self.extractor_settings = self._declare_parameters(
            CORE_PARAMETERS, lambda **values: ExtractorSettings(**values).validate(),
            NODE_PARAMETERS, NodeSettings)
        self._last: tuple[Header, Extraction] | None = None
        self._no_intensities = False
        self._landmarks_pub = self.create_publisher(PointCloud2, "landmarks", STREAM_QOS)
        self._markers_pub = self.create_publisher(MarkerArray, "~/markers", STREAM_QOS)
        self.create_subscription(LaserScan, "scan", self.on_scan, INPUT_QOS)
        self.create_timer(DIAGNOSTICS_PERIOD, self._on_timer)
        s = self.extractor_settings
        self.get_logger().info(f"landmark extractor: detector {s.detector}, ranges "
                               f"[{s.min_range}, {s.max_range}) m")

    def on_scan(self, msg: LaserScan) -> None:
        """Subscription callback: extract the scan's landmarks and publish them."""
        self.stats["received_scan"] += 1
        self._run_callback("scan", self._handle_scan, msg)

    def _handle_scan(self, msg: LaserScan) -> None:
        if not self._frame_ok("scan_frame", msg.header.frame_id, "scan"):
            return
        try:
            scan = extractor_io.read_scan(msg)
        except extractor_io.MalformedScanError as error:
            return self._drop("malformed_scan", f"scan dropped: {error}")
        now = self._now()
        stamp = self._reading_stamp(msg.header.stamp, "scan", now)
        if stamp is None:
            return
        extraction = extract_landmarks(scan, self.extractor_settings)
        self._no_intensities = len(scan.intensities) == 0
        self._last_reading_stamp = stamp
        self.stats["used_scan"] += 1
        self.stats["landmarks"] += len(extraction.landmarks)
        self.stats["reflectors"] += int(extraction.landmarks.reflector.sum())
        for reason, count in extraction.rejected.items():
            self.stats[f"rejected_{reason}"] += count
        header = Header(stamp=msg.header.stamp, frame_id=msg.header.frame_id)
        self._publish(self._landmarks_pub,
                      extractor_io.landmark_cloud(header, extraction.landmarks))
        self._last = (header, extraction)
        self._note_lag(stamp)
        self._publish_throttled(now)

    def reset(self) -> None:
        """Forget the input time (a looped bag); the extractor keeps no state."""
        self._reset_inputs()

    def flush(self) -> None:
        """Publish the markers of the last scan and the diagnostics now (end of a bag)."""
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
        if self._no_intensities and self.extractor_settings.detector != "circles":
            return [f"detector '{self.extractor_settings.detector}' needs intensities; the "
                    "scans carry none (no reflectors can be found)"]
        return []


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
