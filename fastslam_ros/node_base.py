# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The ROS side that both nodes share: start-up, parameters, input gates, diagnostics, outputs.

``FilterNode`` is an rclpy node that feeds readings (landmark clouds, laser scans) and odometry
to a filter in stamp order, each reading at the odometry pose interpolated at its stamp. It
holds what the SLAM node and the people tracker do the same way: parameters declared from
their specs (core ones fixed at start, ROS-side ones changeable at runtime), the bad-input
gates (frames, orientations, invalid and outlier stamps, time going backwards, implausible
odometry), every drop counted and warned about (throttled), the input-rate watch, /diagnostics,
map -> odom and ``_publish``. A subclass adds its filter: ``_set_up``, ``_update``,
``_predict``, ``_publish_throttled`` and ``reset``. A replay runs the node in-process through
``tools/bags/in_process.py``, which overrides the clock, ``_publish`` and the message builders.
"""
from __future__ import annotations

import bisect
import math
import time
from typing import Any, Callable, Protocol

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, KeyValue
from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Odometry
from rclpy.exceptions import (ParameterException)
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Header

from fastslam_ros import ros_io
from fastslam_ros.core.geometry import compose, relative_pose, wrap_scalar
from fastslam_ros.core.sweep import STILL, Motion, SweepMotion, sweep_duration, sweep_end
from fastslam_ros.node_diagnostics import (DIAGNOSTICS_PERIOD, NO_CLOCK_WARNING,
                                           DiagnosticsReporting)
from fastslam_ros.node_parameters import ParameterError, ParameterHandling
from fastslam_ros.node_support.timing import (MAX_ODOMETRY_COORDINATE, STAMP_CONFIRMATIONS,
                                              InputRate, OdometryGate, OdometryHistory, StampGate,
                                              Throttle)

try:  # Only a full ROS install has tf2_ros; ~/map_to_odom carries the same transform anyway.
    from tf2_ros import TransformBroadcaster
except ImportError:
    TransformBroadcaster = None

WARNING_PERIOD = 5.0
"""Seconds between two log warnings of the same kind."""

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

GATE_COUNTERS = (
    "received_odom", "used_odom", "resets", "time_jumps",
    "odometry_jumps",         # confirmed odometry discontinuities, bridged with zero motion
    "odom_missing",           # odometry messages estimated lost from gaps in the stamps
    "dropped_wrong_frame", "dropped_invalid_quaternion", "dropped_nan",
    "dropped_implausible_odometry", "dropped_invalid_stamp", "dropped_outlier_stamp",
    "dropped_duplicate_stamp", "dropped_time_backwards", "dropped_stale",
    "dropped_internal_error",
)
"""Counters every FilterNode has (its own COUNTERS list them, in its order)."""
READING_GATE_COUNTERS = ("resets", "time_jumps", "dropped_wrong_frame", "dropped_invalid_stamp",
                         "dropped_outlier_stamp", "dropped_duplicate_stamp",
                         "dropped_internal_error")
"""Counters of a FilterNode without odometry (``_start_inputs(odometry=False)``)."""


class Reading(Protocol):
    """A queued sensor reading: its stamp, its arrival (node time, s) and the stamp up to which
    it waits for odometry (its own, or its sweep's end: ``sweep.sweep_end``)."""

    stamp: float
    arrival: float
    odometry_until: float


class _NothingToDestroy:
    """Stands in for a part that a failed ``Node.__init__`` never made."""

    def destroy(self) -> None:
        pass


class FilterNode(ParameterHandling, DiagnosticsReporting, Node):
    """Readings and odometry in, in stamp order, through the shared input gates."""

    NODE_NAME = ""
    """The node's name (a subclass sets it)."""

    def __init__(self, **node_kwargs) -> None:
        """Create the rcl node ``NODE_NAME``, then ``_set_up`` (ParameterError on a bad value).

        A failed start destroys the half-built node at once: left to the garbage collector, its
        DDS participant would be torn down at some later, arbitrary point (Fast DDS can then
        block the whole process)."""
        try:
            super().__init__(self.NODE_NAME, **node_kwargs)
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

    # --- to be provided by the node ------------------------------------------------------------

    def _set_up(self) -> None:
        """Everything of the start after the rcl node exists (calls ``_start_inputs`` first)."""
        raise NotImplementedError

    def _update(self, reading: Reading) -> None:
        """Run the filter on one reading whose odometry has arrived."""
        raise NotImplementedError

    def _predict(self, pose_from: np.ndarray, pose_to: np.ndarray) -> None:
        """Move the filter by one odometry step."""
        raise NotImplementedError

    def _publish_throttled(self, now: float) -> None:
        """The outputs that are published at most at their rate (node time ``now``)."""
        raise NotImplementedError

    def reset(self) -> None:
        """Forget the estimate's history and all buffered input (calls ``_reset_inputs``)."""
        raise NotImplementedError

    def _on_first_odometry(self, pose: np.ndarray) -> None:
        """The first odometry pose after a start or a reset, before it is stored."""

    def _diagnostic_state(self) -> list[KeyValue]:
        """Values of the node's own state for /diagnostics."""
        return []

    def _standing_problems(self) -> list[str]:
        """Conditions that make /diagnostics WARN for as long as they last."""
        return []

    # --- set-up --------------------------------------------------------------------------------

    def _start_inputs(self, counters: tuple[str, ...], reading_topic: str, reading_name: str,
                      stale_counter: str, throttled_outputs: tuple[str, ...],
                      diagnosed: tuple[tuple[str, str], ...], odometry: bool = True) -> None:
        """The shared state: counters, gates, input rates of ``odom`` and ``reading_topic``
        (``{topic}_missing`` counters), the pending readings, the shared publishers.

        ``throttled_outputs`` are the rate parameters that get a Throttle; ``diagnosed`` the
        (counter, words) that /diagnostics reports when they grow. A node without
        ``odometry`` (the landmark extractor) has no ``odom`` rate and no map -> odom output,
        and needs only READING_GATE_COUNTERS."""
        gates = (*GATE_COUNTERS, stale_counter) if odometry else READING_GATE_COUNTERS
        missing = [name for name in (*gates, f"{reading_topic}_missing")
                   if name not in counters]
        assert not missing, f"counters missing: {missing}"
        self._last_header: tuple[Any, Header | None] = (None, None)
        self._counter_values: dict[str, tuple[int, KeyValue]] = {}
        self.stats: dict[str, int] = dict.fromkeys(counters, 0)
        self.settings: dict[str, Any] = {}
        """Current values of the ROS-side parameters (runtime changes land here)."""
        self._first_frames: dict[str, str] = {}
        """Per frame parameter left empty: the first frame its readings came in."""
        self._throttled_outputs = throttled_outputs
        self._throttles: dict[str, Throttle] = {}
        self._reading_name, self._stale_counter = reading_name, stale_counter
        self._diagnosed = diagnosed
        self._odometry = OdometryHistory()
        self._sweeps = SweepMotion()
        self._odometry_gate = OdometryGate()
        self._stamp_gate = StampGate()
        self._rates = {reading_topic: InputRate()}
        self._pending: list[Reading] = []
        self._last_reading_stamp: float | None = None
        """Stamp of the newest reading used (a reading with the same stamp is a duplicate)."""
        self._worst_lag = 0.0
        self._worst_callback = 0.0
        self._reported: dict[str, int] = {}
        self._warned: dict[str, float] = {}
        self._diagnostics_throttle = Throttle(1.0 / DIAGNOSTICS_PERIOD)
        self._first_report: float | None = None
        """Node time of the first /diagnostics report (``_never_received`` counts from it)."""
        self._tf_checked = False
        self._diagnostics_pub = self.create_publisher(DiagnosticArray, "/diagnostics", STREAM_QOS)
        self._tf_broadcaster = None
        if odometry:
            self._start_odometry()
        self._clock_check = self.create_timer(NO_CLOCK_WARNING, self._check_clock,
                                              clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _start_odometry(self, map_to_odom: bool = True) -> None:
        """The ``odom`` input's rate and counters (GATE_COUNTERS missing from ``stats`` are
        added) and, with ``map_to_odom``, the map -> odom output. ``_start_inputs`` calls it;
        a node started with ``odometry=False`` may call it once its parameters ask for
        odometry (the landmark extractor's static filter), the caller subscribing ``odom``."""
        for name in (*GATE_COUNTERS, self._stale_counter):
            self.stats.setdefault(name, 0)
        self._rates = {"odom": InputRate(), **self._rates}
        if map_to_odom:
            self._map_to_odom_pub = self.create_publisher(TransformStamped, "~/map_to_odom",
                                                          STREAM_QOS)
            self._tf_broadcaster = TransformBroadcaster(self) if TransformBroadcaster else None

    # --- input gates ---------------------------------------------------------------------------

    def _run_callback(self, what: str, handler: Callable[[Any], None], msg: Any) -> None:
        """Run a subscription handler; an exception is counted as an internal error (a callback
        must never raise), and its duration goes to the diagnostics."""
        start = time.perf_counter()
        try:
            handler(msg)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"{what} callback failed: {error!r}")
        self._worst_callback = max(self._worst_callback, time.perf_counter() - start)

    def on_odometry(self, msg: Odometry) -> None:
        """Subscription callback: store the odometry pose, then run what it makes ready."""
        self.stats["received_odom"] += 1
        self._run_callback("odometry", self._handle_odometry, msg)

    def _drop(self, reason: str, message: str, count: int = 1) -> None:
        """Count dropped input by reason and warn (throttled)."""
        self.stats[f"dropped_{reason}"] += count
        self._warn(f"dropped_{reason}", f"{message} [dropped_{reason}]")

    def _warn(self, kind: str, message: str) -> None:
        """Log a warning, at most one of each ``kind`` per WARNING_PERIOD (wall time). rclpy's
        own throttle inspects the caller's stack on every call, suppressed or not: on a stream
        of bad input that costs more than the filter."""
        now = time.monotonic()
        if now - self._warned.get(kind, -math.inf) >= WARNING_PERIOD:
            self._warned[kind] = now
            self.get_logger().warning(message)

    def _now_ns(self) -> int:
        """Node time (ns): the rclpy clock's (/clock with use_sim_time)."""
        return self.get_clock().now().nanoseconds

    def _now(self) -> float:
        return self._now_ns() * 1e-9

    def _frame_ok(self, parameter: str, frame_id: str, what: str) -> bool:
        """Whether a frame id matches its parameter (an empty id or parameter matches all);
        counts and warns when not."""
        frame, expected = frame_id.lstrip("/"), self.settings[parameter]
        if not frame or not expected or frame == expected:
            return True
        self._drop("wrong_frame", f"{what} frame '{frame}' is not '{expected}' "
                                  f"(parameter {parameter})")
        return False

    def _sensor_frame_ok(self, parameter: str, frame_id: str, what: str) -> bool:
        """``_frame_ok`` for a sensor's readings; with the parameter empty, the first frame
        they came in is the expected one: a reading in another frame is dropped (counted),
        as its coordinates are another sensor's."""
        if not self._frame_ok(parameter, frame_id, what):
            return False
        frame = frame_id.lstrip("/")
        if self.settings[parameter] or not frame:
            return True
        first = self._first_frames.setdefault(parameter, frame)
        if frame == first:
            return True
        self._drop("wrong_frame", f"{what} frame '{frame}' is not the first {what}'s "
                                  f"'{first}' (set {parameter} to choose)")
        return False

    def _stamp(self, stamp_msg, what: str) -> float | None:
        """Seconds of a message's stamp, or None (counted) for an invalid or an outlier stamp.

        A confirmed jump back (a looped bag) runs the queued readings, then resets; a
        confirmed jump forward (a pause) goes on. Either way the gap is no message loss."""
        try:
            stamp = ros_io.checked_stamp_to_seconds(stamp_msg)
        except ros_io.InvalidStampError as error:
            self._drop("invalid_stamp", f"{what} dropped: {error}")
            return None
        newest = self._stamp_gate.newest
        verdict = self._stamp_gate.check(stamp)
        if verdict == StampGate.USABLE:
            return stamp
        if verdict == StampGate.OUTLIER:
            self._drop("outlier_stamp", f"{what} stamped {stamp:.3f} s, {stamp - newest:+.3f} s "
                                        f"from the newest input ({newest:.3f} s): dropped until "
                                        f"{STAMP_CONFIRMATIONS} messages in a row agree")
            return None
        self.stats["time_jumps"] += 1
        self._rates = {topic: InputRate() for topic in self._rates}  # the gap is no loss
        if verdict == StampGate.BACKWARDS:
            self._warn("time_jumps", f"time went backwards from {newest:.3f} s to "
                                     f"{stamp:.3f} s (looped bag?): resetting the filter")
            self._process_ready(self._now(), force=True)
            self.reset()
            self._stamp_gate.check(stamp)  # the new time, after the reset forgot the old one
        else:
            self._warn("time_jumps", f"time jumped forward from {newest:.3f} s to {stamp:.3f} s")
        return stamp

    def _pose_input(self, msg, what: str) -> np.ndarray | None:
        """Planar pose of an Odometry or a PoseWithCovariance(Stamped); None (counted) when its
        orientation or position is not usable."""
        try:
            return ros_io.odometry_pose(msg)
        except ros_io.InvalidQuaternionError as error:
            self._drop("invalid_quaternion", f"{what} dropped: {error}")
        except ros_io.NonFiniteError as error:
            self._drop("nan", f"{what} dropped: {error}")
        return None

    def _initial_pose_input(self, msg: PoseWithCovarianceStamped
                            ) -> tuple[np.ndarray, np.ndarray] | None:
        """(pose, covariance over x, y, yaw) of an ``initialpose`` in the map frame, or None
        (counted) for a wrong frame, a bad pose or a covariance that is no covariance."""
        if not self._frame_ok("map_frame", msg.header.frame_id, "initialpose"):
            return None
        pose = self._pose_input(msg, "initialpose")
        if pose is None:
            return None
        covariance = ros_io.planar_covariance(msg.pose.covariance)
        if covariance is None:
            self._drop("nan", "initialpose dropped: covariance not finite and positive "
                              "semi-definite in x, y, yaw")
            return None
        return pose, covariance

    def _handle_odometry(self, msg: Odometry) -> None:
        """Gate the odometry (frames, pose, stamp, plausibility), store it, run the readings it
        makes ready and predict through what is older than max_observation_wait."""
        if not (self._frame_ok("odom_frame", msg.header.frame_id, "odometry")
                and self._frame_ok("base_frame", msg.child_frame_id, "odometry child")):
            return
        pose = self._pose_input(msg, "odometry")
        if pose is None:
            return
        if not (abs(pose[0]) <= MAX_ODOMETRY_COORDINATE
                and abs(pose[1]) <= MAX_ODOMETRY_COORDINATE):
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
        pose = self._odometry_gate.corrected(pose)
        if latest is not None and not self._odometry_plausible(stamp, pose):
            return
        if latest is None:
            self._on_first_odometry(pose)
        self._odometry.append(stamp, pose)
        now = self._now()
        self.stats["odom_missing"] += self._rates["odom"].record(stamp, now)
        self.stats["used_odom"] += 1
        self._process_ready(now)
        self._advance_idle()
        self._publish_throttled(now)

    def _odometry_plausible(self, stamp: float, pose: np.ndarray) -> bool:
        """The max_speed / max_yaw_rate gate (``OdometryGate``): False (counted) for a jump not
        yet confirmed; a confirmed one is bridged (``pose`` becomes the newest pose)."""
        latest_stamp, latest_pose = self._odometry.latest_stamp, self._odometry.latest_pose
        speed, yaw_rate = self.settings["max_speed"], self.settings["max_yaw_rate"]
        verdict = self._odometry_gate.check(latest_stamp, latest_pose, stamp, pose, speed,
                                            yaw_rate)
        if verdict == OdometryGate.IMPLAUSIBLE:
            self._drop("implausible_odometry",
                       f"odometry jumps {math.hypot(*(pose[:2] - latest_pose[:2])):.3g} m, "
                       f"{abs(wrap_scalar(pose[2] - latest_pose[2])):.3g} rad in "
                       f"{stamp - latest_stamp:.3g} s (max_speed {speed} m/s, max_yaw_rate "
                       f"{yaw_rate} rad/s)")
            return False
        if verdict == OdometryGate.BRIDGED:
            self.stats["odometry_jumps"] += 1
            self._warn("odometry_jumps", "odometry jumped and the jump is confirmed: continuing "
                                         "from the current estimate")
        return True

    def _reading_stamp(self, stamp_msg, topic: str, now: float) -> float | None:
        """Stamp of a reading on ``topic`` arriving at ``now`` (rate watched), or None (counted)
        when invalid, an outlier or a repeat of a queued or used reading's stamp."""
        stamp = self._stamp(stamp_msg, self._reading_name)
        if stamp is None:
            return None
        self.stats[f"{topic}_missing"] += self._rates[topic].record(stamp, now)
        if stamp == self._last_reading_stamp or any(r.stamp == stamp for r in self._pending):
            self._drop("duplicate_stamp", f"{self._reading_name} with a repeated stamp "
                                          f"{stamp:.9f}")
            return None
        return stamp

    def _queue(self, reading: Reading | None, now: float) -> None:
        """Queue a reading by stamp (None: nothing to queue), run what is ready, publish."""
        if reading is not None:
            bisect.insort(self._pending, reading, key=lambda r: r.stamp)
        self._process_ready(now)
        self._publish_throttled(now)

    # --- feeding the filter --------------------------------------------------------------------

    def _process_ready(self, now: float, force: bool = False) -> None:
        """Run the filter on queued readings, oldest first, whose odometry has arrived.

        A reading that waited longer than max_observation_wait (or any, with ``force``) runs
        at the newest odometry; without any odometry it is dropped as stale.
        """
        while self._pending:
            reading = self._pending[0]
            waited = now - reading.arrival
            waited_enough = force or waited > self.settings["max_observation_wait"]
            if not self._odometry.covers(reading.odometry_until):
                if not waited_enough:
                    return
                if self._odometry.latest_stamp is None:
                    self._pending.pop(0)
                    self._drop("stale", f"{self._reading_name} dropped: no odometry has arrived")
                    continue
                self.stats[self._stale_counter] += not self._odometry.covers(reading.stamp)
            self._pending.pop(0)
            self._update(reading)

    def _advance_idle(self) -> None:
        """Predict through odometry older than max_observation_wait, so the history stays short
        and a robot that sees nothing still moves in small steps."""
        latest = self._odometry.latest_stamp
        if latest is not None:
            horizon = latest - self.settings["max_observation_wait"]
            for pose_from, pose_to in self._odometry.advance(horizon):
                self._predict(pose_from, pose_to)

    @staticmethod
    def _odometry_until(stamp: float, time_increment: float, beams: int, deskew: bool
                        ) -> float:
        """The stamp up to which a scan of ``stamp`` waits for odometry: its sweep's end when
        it is to be ``deskew``-ed (``sweep.sweep_end``), else its own."""
        return sweep_end(stamp, time_increment, beams) if deskew else stamp

    def _read_scan(self, msg, read: Callable[[Any, int], Any], max_beams: int
                   ) -> tuple[Any, float, float] | None:
        """A ``sensor_msgs/LaserScan`` in the expected ``scan_frame``, converted by ``read``
        (``ros_io.scan_geometry``'s checks, at most ``max_beams``), with its stamp (s) and the
        time of arrival; None for one dropped (counted and warned)."""
        if not self._sensor_frame_ok("scan_frame", msg.header.frame_id, "scan"):
            return None
        try:
            scan = read(msg, max_beams)
        except ros_io.OversizedError as error:
            self._drop("oversized_scan", f"scan dropped: {error}")
            return None
        except ros_io.MalformedScanError as error:
            self._drop("malformed_scan", f"scan dropped: {error}")
            return None
        now = self._now()
        stamp = self._reading_stamp(msg.header.stamp, "scan", now)
        return None if stamp is None else (scan, stamp, now)

    def _sweep_motion(self, stamp: float, time_increment: float, beams: int,
                      offset: np.ndarray, enabled: bool) -> Motion:
        """The laser's motion over the sweep of a scan of ``stamp`` (the odometry's anchor
        there): the odometry's over the sweep, or since the previous scan when the odometry
        does not reach the sweep's end; STILL when not ``enabled`` or when there is none to
        trust, then counted (``scans_not_deskewed``) and warned."""
        end = self._odometry.pose_at(stamp + sweep_duration(time_increment, beams))
        motion, problem = self._sweeps.motion(stamp, self._odometry.anchor_pose, time_increment,
                                              beams, offset, end)
        if not enabled:
            return STILL
        if problem:
            self.stats["scans_not_deskewed"] += 1
            self._warn("scans_not_deskewed", f"scan not deskewed: {problem} "
                                             "[scans_not_deskewed]")
        return motion

    def _predict_to(self, stamp: float, late_counter: str) -> None:
        """Predict to a reading's stamp (one older than the filter's time counts as late)."""
        if stamp < self._odometry.anchor_stamp:
            self.stats[late_counter] += 1
        for pose_from, pose_to in self._odometry.advance(stamp):
            self._predict(pose_from, pose_to)

    def _note_lag(self, stamp: float) -> None:
        """A reading of ``stamp`` was just used: the lag behind its stamp (node time)."""
        self._worst_lag = max(self._worst_lag, self._now() - stamp)

    def _reset_inputs(self) -> None:
        """Forget the odometry, its frame correction, the input time and the queued readings."""
        self._odometry = OdometryHistory()
        self._sweeps.clear()
        self._odometry_gate.clear()
        self._stamp_gate.clear()
        self._pending.clear()
        self._last_reading_stamp = None
        self.stats["resets"] += 1

    # --- outputs -------------------------------------------------------------------------------

    def _publish(self, publisher, msg) -> None:
        """Publish one output (every output of the node goes through here)."""
        publisher.publish(msg)

    def _pose_message(self, header: Header, pose: np.ndarray,
                      covariance: np.ndarray) -> PoseWithCovarianceStamped:
        """The ``~/pose`` message of a planar pose and its covariance over x, y, yaw."""
        return ros_io.pose_with_covariance(header, pose, covariance)

    def _transform_message(self, header: Header, child_frame_id: str,
                           pose: np.ndarray) -> TransformStamped:
        """The transform of a planar pose of ``child_frame_id`` (``~/map_to_odom``)."""
        return ros_io.transform(header, child_frame_id, pose)

    def _map_header(self, stamp: float) -> Header:
        """The map-frame header at ``stamp``: one object for every output of that stamp (the
        pose, the transform and the throttled outputs of a reading), which no output changes."""
        key = (stamp, self.settings["map_frame"])
        if self._last_header[0] != key:
            self._last_header = (key, Header(stamp=ros_io.seconds_to_stamp(stamp),
                                             frame_id=key[1]))
        return self._last_header[1]

    def _publish_map_to_odom(self, header: Header, pose: np.ndarray) -> None:
        """~/map_to_odom (and /tf when publish_tf) for the robot at ``pose`` in the map at the
        filter's time: (map -> base) * (odom -> base)^-1, the correction taking the filter's
        odometry frame back to the raw one."""
        map_to_odom = compose(compose(pose, relative_pose(self._odometry.anchor_pose,
                                                          np.zeros(3))),
                              self._odometry_gate.correction)
        transform = self._transform_message(header, self.settings["odom_frame"], map_to_odom)
        self._publish(self._map_to_odom_pub, transform)
        self._broadcast_tf(transform)

    def _broadcast_tf(self, transform: TransformStamped) -> None:
        """map -> odom on /tf, when publish_tf and tf2_ros is installed."""
        if self.settings["publish_tf"] and self._tf_broadcaster:
            self._tf_broadcaster.sendTransform(transform)

    def _on_timer(self) -> None:
        """Once a second: run readings that waited too long even if no input arrives any more."""
        try:
            now = self._now()
            self._check_tf_once()
            self._process_ready(now)
            self._publish_throttled(now)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"timer callback failed: {error!r}")

    def _check_tf_once(self) -> None:
        """At the first tick: say once that ``publish_tf`` cannot be honoured without
        tf2_ros."""
        if self._tf_checked:
            return
        self._tf_checked = True
        if self.settings.get("publish_tf") and TransformBroadcaster is None:
            self.get_logger().warning(
                "publish_tf is true but tf2_ros is not installed: map -> odom is published on "
                "~/map_to_odom only, not on /tf (install ROS 2's tf2_ros, or set publish_tf "
                "false)")

    def destroy_node(self) -> None:
        """Destroy, then log the counters (after destruction the log skips /rosout, whose
        publisher is gone when Ctrl-C has already shut the context down)."""
        super().destroy_node()
        counts = ", ".join(f"{key}={value}" for key, value in self.stats.items() if value)
        self.get_logger().info(f"input summary: {counts or 'no input received'}")
