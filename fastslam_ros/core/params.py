# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""One source for every parameter: default, range, choices and description.

A settings dataclass declares each field with ``parameter(...)``; the node's ROS descriptors,
the start-up validation, the commented YAML and the README table are all derived from the
field's metadata (``specs``), so a default or a range is written once.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

SPEC_KEY = "fastslam_spec"


class ParameterValueError(ValueError):
    """A bad parameter value; ``names`` are the parameters at fault (two for a rule between
    them), and the message starts with them."""

    def __init__(self, names: str | tuple[str, ...], reason: str) -> None:
        self.names = (names,) if isinstance(names, str) else tuple(names)
        self.reason = reason
        super().__init__(f"{', '.join(self.names)}: {reason}")


@dataclass(frozen=True)
class Spec:
    """What a parameter accepts and means (numbers: a range; strings: a set of choices)."""

    description: str
    low: float | None = None
    """Lower bound (inclusive unless ``low_exclusive``); None: unbounded."""
    high: float | None = None
    """Upper bound (inclusive unless ``high_exclusive``); None: unbounded."""
    low_exclusive: bool = False
    high_exclusive: bool = False
    choices: tuple[str, ...] | None = None

    @staticmethod
    def _number(value: float) -> str:
        """A bound as people write it: 1000000, not 1e+06; 3.14159 for pi."""
        return str(int(value)) if float(value).is_integer() and abs(value) < 1e15 else f"{value:g}"

    def rule(self) -> str:
        """The accepted values in words, as an error message or a table states them."""
        if self.choices is not None:
            return "one of " + " | ".join(self.choices)
        if self.low is not None and self.high is not None:
            left = "(" if self.low_exclusive else "["
            right = ")" if self.high_exclusive else "]"
            return f"in {left}{self._number(self.low)}, {self._number(self.high)}{right}"
        if self.low is not None:
            return ("> " if self.low_exclusive else ">= ") + self._number(self.low)
        if self.high is not None:
            return ("< " if self.high_exclusive else "<= ") + self._number(self.high)
        return "any value"

    def problem(self, value: Any) -> str | None:
        """Why ``value`` is not accepted, or None when it is."""
        if self.choices is not None:
            return None if value in self.choices else self.rule()
        if isinstance(value, bool):
            return None
        if isinstance(value, float) and not math.isfinite(value):
            return "finite"
        if self.low is not None and (value < self.low
                                     or (self.low_exclusive and value == self.low)):
            return self.rule()
        if self.high is not None and (value > self.high
                                      or (self.high_exclusive and value == self.high)):
            return self.rule()
        return None


def parameter(default: Any, description: str, **limits: Any) -> Any:
    """A dataclass field carrying its ``Spec`` (keyword arguments as ``Spec``'s fields)."""
    return dataclasses.field(default=default, metadata={SPEC_KEY: Spec(description, **limits)})


def specs(settings: type | object) -> dict[str, tuple[Any, Spec]]:
    """{name: (default, spec)} of every field declared with ``parameter``, in declaration order."""
    return {field.name: (field.default, field.metadata[SPEC_KEY])
            for field in dataclasses.fields(settings) if SPEC_KEY in field.metadata}


def check_fields(settings: object) -> None:
    """Raise ``ParameterValueError`` naming the first field whose type, range or choice is wrong."""
    for name, (default, spec) in specs(settings).items():
        value = getattr(settings, name)
        kind = type(default)
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            raise ParameterValueError(name, f"must be a {kind.__name__} (got {value!r})")
        problem = spec.problem(value)
        if problem is not None:
            raise ParameterValueError(name, f"must be {problem} (got {value!r})")
