# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The parameters of the package's nodes: descriptors derived from the parameter specs (range,
description, fixed or changeable), the one-line ``ParameterError``, and ``ParameterHandling``,
the part of ``FilterNode`` that declares, checks and applies them (core ones fixed at start,
ROS-side ones changeable at runtime, unknown names refused)."""
from __future__ import annotations

import math
from typing import Any, Callable

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)
from rclpy.exceptions import (InvalidParameterTypeException, InvalidParameterValueException,
                              ParameterException)
from rclpy.parameter import Parameter

from fastslam_ros.core.params import ParameterValueError, Spec, parameter
from fastslam_ros.node_start import type_problem
from fastslam_ros.node_support.timing import Throttle

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


class ParameterHandling:
    """``FilterNode``'s parameters: declared from specs, checked at start and on change."""

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
