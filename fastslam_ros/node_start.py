# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""What a console command checks before it starts: the shape of a parameter file, its
sections that name no node of the package, and the one-line argument errors.

Kept free of rclpy: the nodes (``node_console.run_node``) and the tools (``tools.cli``) share it.
"""
from __future__ import annotations

import argparse
import os
import sys
from contextlib import contextmanager
from typing import Any, Iterator, NoReturn

PACKAGE_NODES = ("fastslam", "people_tracker")
"""The names of the package's nodes: a section for one of them in a shared parameter file is
not reported when the other node reads the file."""
PARAMETERS_KEY = "ros__parameters"


class ArgumentParser(argparse.ArgumentParser):
    """argparse with the package's error style: one line on stderr, exit status 2."""

    def error(self, message: str) -> NoReturn:
        """``prog: message (see --help)`` instead of the usage block."""
        self.exit(2, f"{self.prog}: {' '.join(message.split())} (see --help)\n")


def params_document_problem(document: Any) -> str | None:
    """Why a parsed YAML document is no ROS 2 parameter file, or None when it is one: a
    mapping of node keys, each holding ``ros__parameters:`` (or, as rcl allows, namespaces
    nesting such keys)."""
    if not isinstance(document, dict) or not document:
        return "no 'NODE: ros__parameters:' sections"
    for key, value in document.items():
        if not _holds_parameters(value):
            return f"section {key!r} holds no {PARAMETERS_KEY}"
    return None


def _holds_parameters(value: Any, depth: int = 0) -> bool:
    if not isinstance(value, dict) or depth > 8:
        return False
    if PARAMETERS_KEY in value:
        return isinstance(value[PARAMETERS_KEY], dict) or value[PARAMETERS_KEY] is None
    return bool(value) and all(_holds_parameters(item, depth + 1) for item in value.values())


def unknown_sections(document: dict, applied: list) -> list[str]:
    """Section keys of a parameter file that neither apply (``applied``, ``/**``) nor name a
    node of the package (``fastslam_node:``, a misspelled name): ignored without a word by rcl."""
    return [str(key) for key in document
            if key != "/**" and key not in applied and "*" not in str(key)
            and str(key).strip("/").rsplit("/", 1)[-1] not in PACKAGE_NODES]


def warn_line(prog: str) -> Any:
    """A ``warn`` callback printing ``prog: warning: message`` as one line on stderr."""
    return lambda message: print(f"{prog}: warning: {message}", file=sys.stderr)


def type_problem(name: str, default: Any, given: Any) -> str:
    """The message for a parameter given a value of another type than its default's: an
    integer for a float says how to write it (``1`` -> ``1.0``)."""
    if isinstance(default, float) and isinstance(given, int) and not isinstance(given, bool):
        return f"parameter '{name}': must be a floating-point number: write {float(given)!r}"
    kinds = {bool: "true or false", int: "an integer", float: "a floating-point number",
             str: "a string"}
    return (f"parameter '{name}': must be {kinds.get(type(default), type(default).__name__)} "
            f"(got {given!r})")


BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""Environment variables by which a user chooses the BLAS threads: set, they are kept."""


def one_blas_thread() -> None:
    """Run numpy's and scipy's BLAS on one thread in this process, unless the user chose
    (``BLAS_THREAD_VARIABLES``). The package's matrices are small (stacked 2x2 and 3x3, a
    sparse factorization of a few thousand unknowns), where OpenBLAS's threads wait on each
    other more than they work, and take a core from the rest of the robot."""
    if not any(name in os.environ for name in BLAS_THREAD_VARIABLES):
        from threadpoolctl import threadpool_limits  # noqa: PLC0415 (scans the loaded libraries)
        threadpool_limits(1, user_api="blas")


@contextmanager
def interrupts_unreported() -> Iterator[None]:
    """Within the block, a KeyboardInterrupt that Python cannot raise (Ctrl-C in a ctypes
    callback of numba's compiler: "Exception ignored ...") prints nothing; others as before."""
    previous = sys.unraisablehook

    def hook(unraisable: Any) -> None:
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            previous(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    finally:
        sys.unraisablehook = previous
