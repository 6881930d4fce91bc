# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A node as a console command: its command line, its parameter file read and checked, the
one-line start errors and exit statuses (0, 1 bad parameter value, 2 usage or unreadable file,
130 interrupted), and the spin until Ctrl-C (``run_node``)."""
from __future__ import annotations

import argparse
import re
import sys
from os import PathLike
from typing import Callable

import rclpy
import yaml
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_dict_from_yaml_file
from rclpy.utilities import remove_ros_args

from fastslam_ros.node_parameters import ParameterError
from fastslam_ros.node_start import (ArgumentParser, interrupts_unreported, one_blas_thread,
                                     params_document_problem, unknown_sections, warn_line)

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
    one_blas_thread()
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
