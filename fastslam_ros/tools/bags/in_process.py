# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A node driven in-process by a tool (the replay, the soak test, the tests): no DDS, no waiting.

``in_process(NodeClass)`` is the node class with ``InProcessNode`` ahead of it: the tool calls
the node's subscription callbacks itself, sets the node time before each input
(``set_node_time``, as ``use_sim_time`` with a clock would), and gets every output through
``output_listeners`` instead of DDS, where nobody listens. ``in_process(NodeClass, lean=True)``
also builds the outputs a replay writes most often as plain look-alikes of their messages,
which the replay's recorder serializes directly (``tools/bags/recorder.py``; rclpy builds a
message object per particle, per marker and per sub-message). The production nodes know none
of this: they publish, read their rclpy clock and build rclpy messages.

The node lives in ``isolated_context()``: a context without discovery, invisible to the
robot's ROS graph.
"""
from __future__ import annotations

import functools
import gc
import os
from contextlib import contextmanager
from typing import Any, Callable, Iterator

import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.parameter import Parameter
from std_msgs.msg import Header

from fastslam_ros import ros_io, ros_markers
from fastslam_ros.node import CORE_PARAMETERS, NODE_PARAMETERS, FastSLAMNode, ParameterError

OutputListener = Callable[[str, Any], None]
"""Called with (topic, message) for every output of an in-process node."""


class InProcessNode:
    """Mixin ahead of a ``node_base.FilterNode`` subclass: outputs to ``output_listeners`` only,
    the node time from ``set_node_time``, no /tf broadcast (a replay records /tf from
    ``~/map_to_odom``), and no warnings about /clock or tf2_ros (the tool sets the time and
    never spins the node)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.output_listeners: list[OutputListener] = []
        self._topic_of: dict[Any, str] = {}
        self._node_time_ns: int | None = None
        """Node time given by ``set_node_time``; None: the rclpy clock."""
        super().__init__(*args, **kwargs)

    def set_node_time(self, nanoseconds: int) -> None:
        """Set the node time (ns) before an input: ``_now`` and the /diagnostics stamp read it
        instead of the rclpy clock, whose override and every read build a Time object (a
        replay hands over about 70,000 inputs). Until the first call: the rclpy clock."""
        self._node_time_ns = nanoseconds

    def _now_ns(self) -> int:
        nanoseconds = self._node_time_ns
        return super()._now_ns() if nanoseconds is None else nanoseconds

    def _publish(self, publisher: Any, msg: Any) -> None:
        """Hand the output to every listener, under its publisher's topic."""
        if self.output_listeners:
            topic = self._topic_of.get(publisher)
            if topic is None:  # asking rcl costs more than recording the message
                topic = self._topic_of[publisher] = publisher.topic_name
            for listener in self.output_listeners:
                listener(topic, msg)

    def _broadcast_tf(self, transform: Any) -> None:
        """Nothing: a replay records ``~/map_to_odom`` on /tf itself."""

    def _check_tf_once(self) -> None:
        """Nothing to say about tf2_ros: the node broadcasts nothing."""

    def _check_clock(self) -> None:
        """Nothing to say about /clock: the tool sets the node time."""
        self._clock_check.cancel()


class LeanOutputs:
    """Mixin: ``~/pose`` and ``~/map_to_odom`` as ``ros_io.PoseWithCovarianceStampedView`` and
    ``ros_io.TransformStampedView``."""

    def _pose_message(self, header: Header, pose: np.ndarray,
                      covariance: np.ndarray) -> ros_io.PoseWithCovarianceStampedView:
        return ros_io.pose_with_covariance_view(header, pose, covariance)

    def _transform_message(self, header: Header, child_frame_id: str,
                           pose: np.ndarray) -> ros_io.TransformStampedView:
        return ros_io.transform_view(header, child_frame_id, pose)


class LeanSLAMOutputs(LeanOutputs):
    """Mixin of a ``FastSLAMNode``: also ``~/particles``, ``~/path`` and ``~/landmarks`` as
    ``ros_io.PlanarPoseArray``, ``ros_io.PathView`` and ``ros_markers.MarkerArrayView``."""

    def _set_up(self) -> None:
        """The node's start, then lean builders with empty caches (what the start published,
        before any listener, is no reuse)."""
        super()._set_up()
        self._path_builder = ros_io.PathBuilder(lean=True)
        self._marker_builder = ros_markers.MarkerBuilder(lean=True)

    def _particles_message(self, header: Header, poses: np.ndarray) -> ros_io.PlanarPoseArray:
        return ros_io.PlanarPoseArray(header, poses)


@functools.cache
def in_process(node_class: type, lean: bool = False) -> type:
    """``node_class`` driven in-process (``InProcessNode``); ``lean``: with look-alike outputs
    (``LeanSLAMOutputs`` for a FastSLAMNode, else ``LeanOutputs``)."""
    mixins: tuple[type, ...] = (InProcessNode,)
    if lean:
        mixins = (LeanSLAMOutputs if issubclass(node_class, FastSLAMNode) else LeanOutputs,
                  *mixins)
    return type(f"InProcess{node_class.__name__}", (*mixins, node_class),
                {"__doc__": f"{node_class.__name__} driven in-process (in_process.py)."})


ISOLATION_ENVIRONMENT = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF", "ROS_STATIC_PEERS": ""}
"""rcl discovery settings of the replay's context: no discovery at all (REP 2009), so its node
never appears on the robot's ROS graph, whatever ROS_DOMAIN_ID says."""


def isolated_context() -> Context:
    """An initialised rclpy Context that discovers nobody and that nobody discovers.

    rcl reads the discovery settings from the environment when the context is initialised;
    they are set for that call only and restored at once."""
    saved = {name: os.environ.get(name) for name in ISOLATION_ENVIRONMENT}
    os.environ.update(ISOLATION_ENVIRONMENT)
    try:
        context = Context()
        rclpy.init(args=[], context=context)  # not sys.argv: its FROM:=TO would be a remap
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
    return context


def node_parameters(params: dict[str, Any], specs: dict[str, tuple[Any, Any]] | None = None
                    ) -> list[Parameter]:
    """rclpy ``Parameter`` overrides for a node (use_sim_time on; an integer given for a
    parameter whose spec default is a float is widened). ``specs``: {name: (default, spec)},
    by default the SLAM node's."""
    specs = {**CORE_PARAMETERS, **NODE_PARAMETERS} if specs is None else specs
    floats = {name for name, (default, _) in specs.items() if isinstance(default, float)}
    overrides = [Parameter("use_sim_time", value=True)]
    for name, value in params.items():
        if name in floats and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        overrides.append(Parameter(name, value=value))
    return overrides


def create_node(node_class: type, context: Context, params: dict[str, Any],
                specs: dict[str, tuple[Any, Any]]) -> Any:
    """A node of ``node_class`` (an in-process one) with these parameters on simulated time;
    ValueError names a bad parameter."""
    try:
        return node_class(context=context, enable_rosout=False,
                          parameter_overrides=node_parameters(params, specs))
    except ParameterError as error:
        raise ValueError(str(error)) from None


@contextmanager
def existing_objects_frozen() -> Iterator[None]:
    """Keep the objects that exist now (modules, compiled kernels, the node) out of the garbage
    collector's scans for the block (``gc.freeze``): a replay allocates enough to trigger full
    collections, and each would scan them all again. Nothing if the caller froze some itself."""
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()
