# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The ROS side that both nodes share: start-up, parameters, input gates, diagnostics, outputs.

``FilterNode`` is an rclpy node that feeds readings (landmark clouds, laser scans) and odometry
to a filter in stamp order, each reading at the odometry pose interpolated at its stamp. It
holds what the SLAM node and the people tracker do the same way: parameters declared from
their specs (core ones fixed at start, ROS-side ones changeable at runtime), the bad-input
gates (frames, orientations, invalid and outlier stamps, time going backwards, implausible
odometry), every drop counted and warned about (throttled), the input-rate watch, /diagnostics,
map -> odom, and ``_publish``, which also hands each message to ``output_listeners`` (a replay
records them). A subclass adds its filter: ``_set_up``, ``_update``, ``_predict``,
``_publish_throttled`` and ``reset``.
"""
from __future__ import annotations

import argparse
import bisect
import math
import re
import sys
import time
from os import PathLike
from typing import Any, Callable, Protocol

import numpy as np
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)
from rclpy.exceptions import (InvalidParameterTypeException, InvalidParameterValueException,
                              ParameterException)
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_dict_from_yaml_file
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.utilities import remove_ros_args
from std_msgs.msg import Header

from fastslam_ros import ros_io
from fastslam_ros.core.geometry import compose, relative_pose, wrap_scalar
from fastslam_ros.core.params import ParameterValueError, Spec, parameter
from fastslam_ros.node_start import (ArgumentParser, interrupts_unreported,
                                     params_document_problem, type_problem, unknown_sections,
                                     warn_line)
from fastslam_ros.node_support.timing import (MAX_ODOMETRY_COORDINATE, STAMP_CONFIRMATIONS,
                                              InputRate, OdometryGate, OdometryHistory, StampGate,
                                              Throttle)

try:  # Only a full ROS install has tf2_ros; ~/map_to_odom carries the same transform anyway.
    from tf2_ros import TransformBroadcaster
except ImportError:
    TransformBroadcaster = None

LAG_WARNING = 1.0
"""s: a reading processed this long after its stamp (node time) makes the diagnostics WARN."""
DIAGNOSTICS_PERIOD = 1.0
"""Seconds of node time between two /diagnostics messages."""
NO_INPUT_WARNING = 5.0
"""s of node time after the first /diagnostics report: an input still never received then
makes the diagnostics WARN, naming its topic."""
NO_CLOCK_WARNING = 5.0
"""s of wall time after start: a node on simulated time whose clock has not moved warns."""
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
FIXED_NOTE = " Fixed at start (restart to change)."
INT64_LIMITS = (-2**63, 2**63 - 1)
GRAPH_PARAMETER_PREFIXES = ("qos_overrides.",)
"""Parameters rclpy declares itself when asked (QoS overrides): never reported as unknown."""

Specs = dict[str, tuple[Any, Spec]]


def max_speed_parameter() -> Any:
    """The ``max_speed`` field of a node's settings (the odometry plausibility gate)."""
    return parameter(
        20.0, "Odometry plausibility gate (m/s): a step between consecutive odometry poses "
        "faster than this is a glitch and dropped, unless the next messages confirm it.",
        low=1e-3, high=1e5)


def max_yaw_rate_parameter() -> Any:
    """The ``max_yaw_rate`` field of a node's settings (the gate on the heading)."""
    return parameter(
        10.0, "Odometry plausibility gate on the heading (rad/s), as max_speed.", low=1e-3,
        high=1e4)


class ParameterError(ValueError):
    """A parameter value that stops the node from starting; the message names the parameter."""


class Reading(Protocol):
    """A queued sensor reading: its stamp and its arrival (node time, s)."""

    stamp: float
    arrival: float


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


def parameter_error(error: ValueError) -> ParameterError:
    """A ParameterError that names the parameter(s) as the user typed them (a settings
    ``ValueError`` reads ``name: reason``)."""
    if isinstance(error, ParameterValueError):
        names, reason = error.names, error.reason
    else:
        name, _, reason = str(error).partition(":")
        names, reason = (name.strip(),), reason.strip()
    quoted = ", ".join(f"'{name}'" for name in names)
    return ParameterError(f"parameter{'s' if len(names) > 1 else ''} {quoted}: {reason}")


class _NothingToDestroy:
    """Stands in for a part that a failed ``Node.__init__`` never made."""

    def destroy(self) -> None:
        pass


class FilterNode(Node):
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
        self.output_listeners: list[Callable[[str, object], None]] = []
        self._topic_names: dict[Any, str] = {}
        self._last_header: tuple[Any, Header | None] = (None, None)
        self._counter_values: dict[str, tuple[int, KeyValue]] = {}
        self.publish_to_dds = True
        """False: outputs go only to ``output_listeners`` (an in-process replay, no DDS cost)."""
        self._node_time_ns: int | None = None
        """Node time given by ``set_node_time`` (an in-process replay); None: the rclpy clock."""
        self.lean_outputs = False
        """True, with ``publish_to_dds`` False: ``~/particles``, ``~/landmarks``, ``~/pose``,
        ``~/map_to_odom`` and ``~/path`` go to the listeners as ``ros_io.PlanarPoseArray``,
        ``ros_markers.MarkerArrayView``, ``ros_io.PoseWithCovarianceStampedView``,
        ``ros_io.TransformStampedView`` and ``ros_io.PathView`` (a replay serializes them
        directly; rclpy builds a message object per particle, per marker and per
        sub-message)."""
        self.stats: dict[str, int] = dict.fromkeys(counters, 0)
        self.settings: dict[str, Any] = {}
        """Current values of the ROS-side parameters (runtime changes land here)."""
        self._throttled_outputs = throttled_outputs
        self._throttles: dict[str, Throttle] = {}
        self._reading_name, self._stale_counter = reading_name, stale_counter
        self._diagnosed = diagnosed
        self._odometry = OdometryHistory()
        self._odometry_gate = OdometryGate()
        self._stamp_gate = StampGate()
        self._rates = {**({"odom": InputRate()} if odometry else {}),
                       reading_topic: InputRate()}
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
            self._map_to_odom_pub = self.create_publisher(TransformStamped, "~/map_to_odom",
                                                          STREAM_QOS)
            self._tf_broadcaster = TransformBroadcaster(self) if TransformBroadcaster else None
        self._clock_check = self.create_timer(NO_CLOCK_WARNING, self._check_clock,
                                              clock=Clock(clock_type=ClockType.STEADY_TIME))

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
        except InvalidParameterTypeException:
            raise ParameterError(type_problem(name, default,
                                              self._parameter_overrides[name].value)) from None
        except ParameterException as error:
            raise ParameterError(f"parameter '{name}': {error}") from None

    def _declare_parameters(self, core_specs: Specs, build_core: Callable[..., Any],
                            node_specs: Specs, node_settings: Callable[..., Any],
                            start_only: tuple[str, ...] = ()) -> Any:
        """Declare every parameter; return the core settings ``build_core(**values)``.

        Core parameters are fixed at start; the ROS-side ones (``node_settings``, a dataclass
        with ``validate()``) land in ``self.settings`` and may change at runtime, but for
        ``start_only`` ones, read once at start. A bad value, a broken rule between values or
        an unknown parameter name raises ParameterError."""
        self._core_specs, self._node_specs, self._node_settings = (core_specs, node_specs,
                                                                   node_settings)
        self._start_only = frozenset(start_only)
        values = {name: self._declare(name, default, spec, FIXED_NOTE)
                  for name, (default, spec) in core_specs.items()}
        try:
            core = build_core(**values)
        except ValueError as error:
            raise parameter_error(error) from None
        values = {name: self._declare(name, default, spec,
                                      FIXED_NOTE if name in self._start_only else "")
                  for name, (default, spec) in node_specs.items()}
        try:
            node_settings(**values).validate()
        except ValueError as error:
            raise parameter_error(error) from None
        self._apply_parameter_change([self.get_parameter(name) for name in node_specs])
        self._check_unknown_parameters()
        self.add_on_set_parameters_callback(self._check_parameter_change)
        self.add_post_set_parameters_callback(self._apply_parameter_change)
        return core

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
            if changed.name in self._core_specs:
                return SetParametersResult(successful=False, reason=(
                    f"{changed.name}: core parameters are fixed while the filter runs; restart "
                    "the node with the new value"))
            if changed.name in self._start_only:
                return SetParametersResult(successful=False, reason=(
                    f"{changed.name}: read at start only; restart the node with the new value"))
            if changed.name in self._node_specs:
                changes[changed.name] = changed.value
        current = {name: self.settings.get(name, default)
                   for name, (default, _) in self._node_specs.items()}
        try:
            self._node_settings(**{**current, **changes}).validate()
        except ValueError as error:
            return SetParametersResult(successful=False, reason=str(parameter_error(error)))
        return SetParametersResult(successful=True)

    def _apply_parameter_change(self, parameters: list[Parameter]) -> None:
        """Cache the ROS-side values the callbacks read; a new rate restarts its throttle."""
        for changed in parameters:
            if changed.name in self._node_specs:
                self.settings[changed.name] = changed.value
            if changed.name in self._throttled_outputs:
                self._throttles[changed.name] = Throttle(changed.value)

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

    def set_node_time(self, nanoseconds: int) -> None:
        """Set the node time (ns) before an input, as an in-process replay does: ``_now`` and the
        /diagnostics stamp read it instead of the rclpy clock, whose override and every read
        build a Time object (a replay hands over about 70,000 inputs). A live node, which never
        calls it, follows its rclpy clock."""
        self._node_time_ns = nanoseconds

    def _now_ns(self) -> int:
        """Node time (ns): ``set_node_time``'s, else the rclpy clock's."""
        nanoseconds = self._node_time_ns
        return self.get_clock().now().nanoseconds if nanoseconds is None else nanoseconds

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
            if not self._odometry.covers(reading.stamp):
                if not waited_enough:
                    return
                if self._odometry.latest_stamp is None:
                    self._pending.pop(0)
                    self._drop("stale", f"{self._reading_name} dropped: no odometry has arrived")
                    continue
                self.stats[self._stale_counter] += 1
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
        self._odometry_gate.clear()
        self._stamp_gate.clear()
        self._pending.clear()
        self._last_reading_stamp = None
        self.stats["resets"] += 1

    # --- outputs -------------------------------------------------------------------------------

    def _lean(self) -> bool:
        """Whether outputs go to the listeners as plain look-alikes (``lean_outputs``)."""
        return self.lean_outputs and not self.publish_to_dds

    def _publish(self, publisher, msg) -> None:
        """Publish and hand the message to every output listener (replay records them)."""
        if self.publish_to_dds:
            publisher.publish(msg)
        if self.output_listeners:
            topic = self._topic_names.get(publisher)
            if topic is None:  # asking rcl costs more than recording the message
                topic = self._topic_names[publisher] = publisher.topic_name
            for listener in self.output_listeners:
                listener(topic, msg)

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
        build = ros_io.transform_view if self._lean() else ros_io.transform
        transform = build(header, self.settings["odom_frame"], map_to_odom)
        self._publish(self._map_to_odom_pub, transform)
        if self.publish_to_dds and self.settings["publish_tf"] and self._tf_broadcaster:
            self._tf_broadcaster.sendTransform(transform)

    def _new_problems(self, now: float) -> list[str]:
        """What went wrong since the last report, worst first: drops, input gaps, silence,
        processing lag, then the node's ``diagnosed`` counters."""
        stats, seen = self.stats, self._reported
        drops = sum(v for k, v in stats.items() if k.startswith("dropped_"))
        counts = {"drops": drops, **{f"{topic}_missing": stats[f"{topic}_missing"]
                                     for topic in self._rates},
                  **{key: stats[key] for key, _ in self._diagnosed}}
        new = {k: v - seen.get(k, 0) for k, v in counts.items()}
        self._reported = counts
        problems = []
        if new["drops"]:
            problems.append(f"{new['drops']} input(s) dropped")
        for topic, rate in self._rates.items():
            if new[f"{topic}_missing"] > 0:
                problems.append(f"~{new[f'{topic}_missing']} {topic} message(s) lost (gaps in "
                                f"the stamps up to {rate.largest_gap:.3g} s, usual interval "
                                f"{rate.interval:.3g} s)")
            if silent := rate.silence(now):
                problems.append(f"no {topic} for {silent:.3g} s (usual interval "
                                f"{rate.interval:.3g} s)")
        problems += self._never_received(now)
        if self._worst_lag > LAG_WARNING:
            problems.append(f"processing lag {self._worst_lag:.3g} s behind the stamps")
        problems += [f"{new[key]} {what}" for key, what in self._diagnosed if new[key]]
        return problems

    def _never_received(self, now: float) -> list[str]:
        """The inputs of which not one message came in NO_INPUT_WARNING s after the first
        report, by their resolved (namespaced, remapped) names: a wrong topic or namespace."""
        if self._first_report is None:
            self._first_report = now
        waited = now - self._first_report
        if waited < NO_INPUT_WARNING:
            return []
        return [f"nothing received on {self.resolve_topic_name(topic)} for {waited:.3g} s"
                for topic in self._rates if not self.stats.get(f"received_{topic}")]

    def _publish_diagnostics(self, component: str = "filter") -> None:
        """/diagnostics: every counter, the node's state, the input rates and the processing
        lag; WARN naming what went wrong since the last report and what still is wrong."""
        now_ns = self._now_ns()
        now = now_ns * 1e-9
        new = self._new_problems(now)
        problems = self._standing_problems() + (["; ".join(new) + " since last report"]
                                                if new else [])
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
            name=f"{self.get_name()}: {component}", hardware_id=self.get_fully_qualified_name(),
            message="; ".join(problems) or "running",
            values=[self._counter_value(k, v) for k, v in self.stats.items()]
            + self._diagnostic_state() + rates + timing)
        self._publish(self._diagnostics_pub, DiagnosticArray(
            header=Header(stamp=ros_io.nanoseconds_to_stamp(now_ns)), status=[status]))

    def _counter_value(self, key: str, count: int) -> KeyValue:
        """The KeyValue of a counter: the one of the last report while the count is the same
        (most counters stay put; no report changes a KeyValue)."""
        cached = self._counter_values.get(key)
        if cached is None or cached[0] != count:
            cached = self._counter_values[key] = (count, KeyValue(key=key, value=str(count)))
        return cached[1]

    def _on_timer(self) -> None:
        """Once a second: run readings that waited too long even if no input arrives any more."""
        try:
            now = self._now()
            self._check_tf_once()
            self._process_ready(now)
            self._publish_throttled(now)
        except Exception as error:  # noqa: BLE001 - a callback must never raise
            self._drop("internal_error", f"timer callback failed: {error!r}")

    def _check_clock(self) -> None:
        """Once, NO_CLOCK_WARNING s of wall time after start: on simulated time with no /clock
        (a bag played without --clock) the node's time stands still, its timer never runs and
        it would say nothing at all."""
        self._clock_check.cancel()
        if (self._node_time_ns is None and self.get_parameter("use_sim_time").value
                and self.get_clock().now().nanoseconds == 0):
            self.get_logger().warning(
                f"use_sim_time is true but no /clock came in {NO_CLOCK_WARNING:g} s: the node's "
                "time stands still and it outputs nothing (play a bag with --clock, or set "
                "use_sim_time false)")

    def _check_tf_once(self) -> None:
        """At the first tick of a live node: say once that ``publish_tf`` cannot be honoured
        without tf2_ros (a replay, which never spins, records /tf itself)."""
        if self._tf_checked:
            return
        self._tf_checked = True
        if self.settings.get("publish_tf") and self.publish_to_dds and TransformBroadcaster is None:
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


# --- console nodes ------------------------------------------------------------------------------

class ParamsFileError(ParameterError):
    """A parameter file that cannot be read or is no ROS 2 parameter file (a usage error)."""


def read_params_file(path: str | PathLike, node_name: str,
                     warn: Callable[[str], None] | None = None,
                     require_section: bool = True) -> dict[str, object]:
    """{name: value} that a ROS 2 parameter file gives the node ``node_name`` (fully
    qualified), read with rclpy's own parser: the ``/**`` section first, then every section
    whose key matches the node (``fastslam``, ``/robot1/fastslam``, ``/**/fastslam``).

    Raises ParamsFileError naming the file when it cannot be read or is no parameter file,
    ParameterError when no section of it applies to the node (``fastslam_node:`` for
    ``fastslam``; {} instead unless ``require_section``); ``warn`` is told of each section
    that names no node of this package.
    """
    try:
        with open(path, encoding="utf-8") as stream:
            document = yaml.safe_load(stream)
        problem = params_document_problem(document)
        if problem:
            raise RuntimeError(problem)
        sections = [key for key in document
                    if key != "/**" and _section_matches(str(key), node_name)]
        ignored = unknown_sections(document, sections)
        if "/**" not in document and not sections:
            if not require_section:
                return {}
            raise ParameterError(
                f"parameter file '{path}': no section for node {node_name}, not one parameter "
                f"applies (sections: {', '.join(map(str, document))}; keys that apply: "
                f"{node_name.lstrip('/')}, /**/{node_name.rsplit('/', 1)[-1]}, /**)")
        if ignored and warn is not None:
            warn(f"parameter file '{path}': section(s) {', '.join(ignored)} name no node of "
                 f"fastslam_ros and are ignored (node {node_name})")
        messages = parameter_dict_from_yaml_file(str(path), use_wildcard=True,
                                                 target_nodes=sections)
    except OSError as error:
        raise ParamsFileError(f"parameter file '{path}': {error.strerror or error}") from None
    except (yaml.YAMLError, UnicodeDecodeError, RuntimeError, AttributeError, TypeError) as error:
        reason = " ".join(str(error).split())
        raise ParamsFileError(f"parameter file '{path}': not a ROS 2 parameter file "
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


def parse_command_line(prog: str, usage: str, args: list[str]) -> None:
    """Handle the arguments that are not ROS arguments: ``--help`` prints the usage and exits;
    anything else is a usage error (exit status 2) instead of being ignored."""
    parser = ArgumentParser(prog=prog, description=usage,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.parse_args(remove_ros_args(args)[1:])


def _interrupted(error: BaseException | None) -> bool:
    """Whether ``error`` is a KeyboardInterrupt or was raised while one was handled: numba,
    interrupted while it compiles the kernels, may raise an error of its own instead."""
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, KeyboardInterrupt):
            return True
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return False


def run_node(prog: str, node_name: str, usage: str, make_node: Callable[[], Node],
             args: list[str] | None = None) -> int:
    """Start, spin and shut down one node as a console command (both nodes' ``main``), with the
    tools' exit status rule (``tools.cli``): a bad parameter value, or a parameter file of
    which nothing applies, is one line on stderr and status 1; a parameter file that cannot be
    read or a bad argument, status 2; Ctrl-C while the node starts, status 130."""
    argv = sys.argv if args is None else args
    try:
        renamed = any(rule in arg for arg in argv for rule in ("__ns:=", "__node:=", "__name:="))
        for path in _params_files(argv):  # one line instead of rcl's failure
            read_params_file(path, f"/{node_name}", warn_line(prog),
                             require_section=not renamed)  # else once the node exists
        parse_command_line(prog, usage, argv)
        rclpy.init(args=args)
    except ParamsFileError as error:
        print(f"{prog}: {' '.join(str(error).split())}", file=sys.stderr)
        return 2
    except ParameterError as error:
        print(f"{prog}: {' '.join(str(error).split())}", file=sys.stderr)
        return 1
    except RuntimeError as error:  # rcl could not parse the arguments
        print(f"{prog}: cannot start: {str(error).splitlines()[0]}", file=sys.stderr)
        return 2
    try:
        with interrupts_unreported():
            node = make_node()
        for path in _params_files(argv) if renamed else ():  # its full name is known now
            try:
                read_params_file(path, node.get_fully_qualified_name())
            except ParameterError:
                node.destroy_node()
                raise
    except ParameterError as error:
        print(f"{prog}: {' '.join(str(error).split())}", file=sys.stderr)
        rclpy.try_shutdown()
        return 1
    except BaseException as error:  # rclpy's SIGINT handler shuts the context down
        if not (_interrupted(error) or not rclpy.ok()):
            raise
        print(f"{prog}: interrupted while starting", file=sys.stderr)
        # Half-built compiler objects fail in their __del__ at exit: nothing to report.
        sys.unraisablehook = lambda unraisable: None
        rclpy.try_shutdown()
        return 130
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
