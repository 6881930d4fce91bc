"""Replay a bag through the real ``FastSLAMNode`` in-process, fast and deterministic.

Every ``/odom`` and ``/landmarks`` message of the bag is deserialized straight into its rclpy
message class and handed, in bag-time order, to the node's subscription callbacks; before each
one the node's clock (``use_sim_time``) is set to the message's bag time. Nothing goes through
DDS and nothing waits, so a replay runs as fast as the filter allows and gives the same
outputs as a live run at the same times. Every message the node publishes is recorded into
OUT (MCAP) at the bag time of the input being processed, together with copies of the bag's
``/odom``, ``/landmarks`` and ground-truth topics and one ``/fastslam_replay/info`` message
(``std_msgs/String``, JSON: wall and CPU time, bag duration, real-time factor, node counters,
the parameters used), so OUT alone is enough for ``fastslam-eval``.
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import math
import sys
import time
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, TextIO

import rclpy
import yaml
from rclpy.clock import ClockType
from rclpy.context import Context
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.time import Time
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.rosbag2 import Writer
from std_msgs.msg import String

from fastslam_ros.core.config import FastSLAMConfig
from fastslam_ros.node import ROS_PARAMETERS, FastSLAMNode, ParameterError
from fastslam_ros.tools.bag_schema import (GROUND_TRUTH_LANDMARKS_TOPIC, GROUND_TRUTH_POSE_TOPIC,
                                           LANDMARKS_TOPIC, ODOM_TOPIC, TYPESTORE, SchemaError,
                                           open_writer)

INFO_TOPIC = "/fastslam_replay/info"
INPUT_TOPICS = (ODOM_TOPIC, LANDMARKS_TOPIC)
COPIED_TOPICS = (ODOM_TOPIC, LANDMARKS_TOPIC, GROUND_TRUTH_POSE_TOPIC,
                 GROUND_TRUTH_LANDMARKS_TOPIC)
NODE_SECTIONS = ("/**", "**", "fastslam", "/fastslam", "people_tracker", "/people_tracker")
"""Sections of a ROS 2 parameter file that apply to the node, later ones winning."""
PROGRESS_PERIOD = 0.25
"""Seconds of wall time between two progress bar updates."""


@dataclass
class ReplayResult:
    """What a replay did: node counters, wall time and bag time (s), the output bag."""

    stats: dict[str, int]
    wall_time: float
    bag_duration: float
    out_path: Path | None
    params: dict[str, Any] = field(default_factory=dict)
    cpu_time: float = 0.0
    """CPU seconds of this process during the replay: the wall time on an idle machine."""

    @property
    def real_time_factor(self) -> float:
        """Bag seconds processed per wall-clock second."""
        return self.bag_duration / self.wall_time if self.wall_time > 0 else math.inf


# ---------------------------------------------------------------- message types


def ros_message_class(msgtype: str) -> type:
    """The rclpy message class of ``pkg/msg/Name``."""
    package, kind, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


def ros_msgtype(msg: Any) -> str:
    """``pkg/msg/Name`` of an rclpy message instance."""
    package = type(msg).__module__.split(".")[0]
    return f"{package}/msg/{type(msg).__name__}"


# ---------------------------------------------------------------- parameters


def load_params_file(path: str | Path) -> dict[str, Any]:
    """The node's parameters from a ROS 2 YAML file (``/**`` and ``fastslam`` sections)."""
    with open(path, encoding="utf-8") as stream:
        document = yaml.safe_load(stream) or {}
    if not isinstance(document, dict):
        raise ValueError(f"{path}: not a ROS 2 parameter file")
    params: dict[str, Any] = {}
    for section in NODE_SECTIONS:
        values = (document.get(section) or {}).get("ros__parameters") or {}
        params.update(values)
    if not params and document:
        raise ValueError(f"{path}: no 'fastslam:' or '/**:' section with ros__parameters")
    return params


def parse_assignment(text: str) -> tuple[str, Any]:
    """``name=value`` with a YAML value (``0.5`` float, ``100`` int, ``ml`` string); numbers
    that YAML 1.1 leaves as strings (``2e-4``) are read as floats."""
    name, separator, value = text.partition("=")
    if not separator or not name:
        raise ValueError(f"expected name=value, got {text!r}")
    parsed = yaml.safe_load(value)
    if isinstance(parsed, str):
        try:
            parsed = float(parsed)
        except ValueError:
            pass
    return name.strip(), parsed


def _declared_float_names() -> set[str]:
    """Parameters declared as doubles: an integer given for them is converted."""
    names = {item.name for item in dataclasses.fields(FastSLAMConfig)
             if isinstance(item.default, float)}
    return names | {name for name, spec in ROS_PARAMETERS.items()
                    if isinstance(spec.default, float)}


def node_parameters(params: dict[str, Any]) -> list[Parameter]:
    """rclpy ``Parameter`` overrides for the node (use_sim_time on, ints widened to doubles)."""
    floats = _declared_float_names()
    overrides = [Parameter("use_sim_time", value=True)]
    for name, value in params.items():
        if name in floats and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        overrides.append(Parameter(name, value=value))
    return overrides


# ---------------------------------------------------------------- progress


class ProgressBar:
    """A one-line progress bar on a stream: fraction, messages per second, ETA, real-time factor."""

    def __init__(self, total: int, stream: TextIO = sys.stderr, width: int = 30) -> None:
        self.total = max(total, 1)
        self.stream = stream
        self.width = width
        self.start = time.monotonic()
        self.last_draw = -math.inf

    def update(self, done: int, bag_elapsed: float, final: bool = False) -> None:
        """Redraw if due (or when ``final``)."""
        now = time.monotonic()
        if not final and now - self.last_draw < PROGRESS_PERIOD:
            return
        self.last_draw = now
        elapsed = max(now - self.start, 1e-9)
        fraction = min(done / self.total, 1.0)
        rate = done / elapsed
        eta = (self.total - done) / rate if rate > 0 else math.inf
        filled = int(round(fraction * self.width))
        bar = "#" * filled + "." * (self.width - filled)
        line = (f"\r[{bar}] {100 * fraction:5.1f}% {done}/{self.total} msgs, {rate:,.0f} msg/s, "
                f"{bag_elapsed / elapsed:.1f}x real time, ETA {eta:4.0f} s ")
        self.stream.write(line + ("\n" if final else ""))
        self.stream.flush()


# ---------------------------------------------------------------- replay


class OutputRecorder:
    """Writes node outputs and copied inputs into an MCAP bag at the current bag time."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.connections: dict[str, Any] = {}
        self.stamp_ns = 0

    def _connection(self, topic: str, msgtype: str) -> Any:
        if topic not in self.connections:
            self.connections[topic] = self.writer.add_connection(topic, msgtype,
                                                                 typestore=TYPESTORE)
        return self.connections[topic]

    def record(self, topic: str, msg: Any) -> None:
        """Output listener of the node: serialize the rclpy message and write it."""
        self.writer.write(self._connection(topic, ros_msgtype(msg)), self.stamp_ns,
                          serialize_message(msg))

    def copy(self, topic: str, msgtype: str, stamp_ns: int, raw: bytes) -> None:
        """Write an input message unchanged."""
        self.writer.write(self._connection(topic, msgtype), stamp_ns, raw)


def replay_bag(bag_path: str | Path, params: dict[str, Any] | None = None,
               params_file: str | Path | None = None, out_path: str | Path | None = None,
               progress: bool = False, overwrite: bool = True) -> ReplayResult:
    """Feed the bag's ``/odom`` and ``/landmarks`` to a fresh ``FastSLAMNode``; record outputs.

    ``params`` override ``params_file``; set ``seed`` in them for a reproducible run. Raises
    ``FileNotFoundError`` / ``SchemaError`` for a missing or unreadable bag or missing topics,
    ``ValueError`` for bad parameters (the message names the parameter).
    """
    bag_path = Path(bag_path)
    merged = load_params_file(params_file) if params_file else {}
    merged.update(params or {})
    context = Context()
    rclpy.init(context=context)
    with ExitStack() as cleanup:
        cleanup.callback(rclpy.try_shutdown, context=context)
        reader = cleanup.enter_context(_open_input(bag_path))
        node = _create_node(context, merged)
        cleanup.callback(node.destroy_node)
        # The association is always recorded: the evaluation matches landmarks by it.
        used_params = {name: node.get_parameter(name).value
                       for name in sorted(set(merged) | {"algorithm", "association"})}
        recorder = None
        if out_path is not None:
            writer = open_writer(out_path, "mcap", overwrite)
            writer.open()
            cleanup.callback(writer.close)
            recorder = OutputRecorder(writer)
            node.output_listeners.append(recorder.record)
        start, start_cpu = time.perf_counter(), time.process_time()
        done, duration = _feed(node, reader, recorder, progress)
        result = ReplayResult(dict(node.stats), time.perf_counter() - start, duration,
                              Path(out_path) if out_path is not None else None, used_params,
                              time.process_time() - start_cpu)
        if recorder is not None:
            info = {"bag": str(bag_path), "wall_time": result.wall_time,
                    "cpu_time": result.cpu_time, "bag_duration": duration,
                    "real_time_factor": result.real_time_factor, "messages": done,
                    "stats": result.stats, "params": used_params}
            recorder.record(INFO_TOPIC, String(data=json.dumps(info)))
        return result


@contextmanager
def _open_input(bag_path: Path) -> Iterator[AnyReader]:
    """An open reader of a bag that has the input topics (SchemaError otherwise)."""
    if not bag_path.exists():
        raise FileNotFoundError(f"bag not found: {bag_path}")
    reader = AnyReader([bag_path], default_typestore=TYPESTORE)
    try:
        reader.open()
    except AnyReaderError as error:
        raise SchemaError(f"cannot read {bag_path}: {error}") from None
    try:
        topics = {c.topic for c in reader.connections}
        missing = [topic for topic in INPUT_TOPICS if topic not in topics]
        if missing:
            raise SchemaError(f"{bag_path}: missing topic(s) {', '.join(missing)} "
                              f"(has: {', '.join(sorted(topics)) or 'none'})")
        yield reader
    finally:
        reader.close()


def _create_node(context: Context, params: dict[str, Any]) -> FastSLAMNode:
    """The node with these parameters on simulated time; ValueError names a bad parameter."""
    try:
        node = FastSLAMNode(context=context, parameter_overrides=node_parameters(params),
                            enable_rosout=False)
    except ParameterError as error:
        raise ValueError(str(error)) from None
    unknown = sorted(name for name in params if not node.has_parameter(name))
    if unknown:
        node.destroy_node()
        raise ValueError(f"unknown parameter(s): {', '.join(unknown)}")
    # Nobody listens over DDS in a replay: outputs go only to the recorder.
    node.publish_to_dds = False
    return node


def _feed(node: FastSLAMNode, reader: AnyReader, recorder: OutputRecorder | None,
          progress: bool) -> tuple[int, float]:
    """Hand every input message to the node at its bag time, then flush; returns the number of
    inputs and the bag time they span (s)."""
    callbacks = {ODOM_TOPIC: node.on_odometry, LANDMARKS_TOPIC: node.on_landmarks}
    classes = {c.topic: ros_message_class(c.msgtype) for c in reader.connections
               if c.topic in INPUT_TOPICS}
    wanted = [c for c in reader.connections
              if c.topic in INPUT_TOPICS or (recorder is not None and c.topic in COPIED_TOPICS)]
    bar = ProgressBar(sum(c.msgcount for c in wanted if c.topic in INPUT_TOPICS)) \
        if progress else None
    clock = node.get_clock()
    first_ns = last_ns = None
    done = 0
    for connection, stamp_ns, raw in reader.messages(connections=wanted):
        if recorder is not None:
            recorder.stamp_ns = stamp_ns
            if connection.topic in COPIED_TOPICS:
                recorder.copy(connection.topic, connection.msgtype, stamp_ns, raw)
        if connection.topic not in INPUT_TOPICS:
            continue
        first_ns = stamp_ns if first_ns is None else first_ns
        last_ns = stamp_ns
        clock.set_ros_time_override(Time(nanoseconds=stamp_ns, clock_type=ClockType.ROS_TIME))
        callbacks[connection.topic](deserialize_message(bytes(raw), classes[connection.topic]))
        done += 1
        if bar is not None:
            bar.update(done, (stamp_ns - first_ns) * 1e-9)
    node.flush()
    duration = (last_ns - first_ns) * 1e-9 if first_ns is not None else 0.0
    if bar is not None:
        bar.update(done, duration, final=True)
    return done, duration


def summary_lines(result: ReplayResult) -> list[str]:
    """Human summary: throughput, messages processed, dropped by reason."""
    stats = result.stats
    lines = [f"replayed {result.bag_duration:.1f} s of data in {result.wall_time:.1f} s "
             f"({result.real_time_factor:.1f}x real time; {result.cpu_time:.1f} s of CPU)",
             "processed: " + ", ".join(f"{key} {value}" for key, value in stats.items()
                                       if not key.startswith("dropped_") and value)]
    dropped = {key[len("dropped_"):]: value for key, value in stats.items()
               if key.startswith("dropped_") and value}
    lines.append("dropped: " + (", ".join(f"{reason} {count}" for reason, count in dropped.items())
                                if dropped else "none"))
    if result.out_path is not None:
        lines.append(f"outputs recorded in {result.out_path}")
    return lines


def main(argv: list[str] | None = None) -> int:
    """``fastslam-replay``: replay a bag through the node; exit 1 on an unusable bag."""
    parser = argparse.ArgumentParser(prog="fastslam-replay",
                                     description=__doc__.split("\n\n")[0].replace("``", ""))
    parser.add_argument("bag", type=Path, help="schema-v1 rosbag2 folder (mcap or sqlite3)")
    parser.add_argument("--params", type=Path, default=None,
                        help="ROS 2 parameter file (fastslam: or /**: ros__parameters)")
    parser.add_argument("--set", dest="assignments", action="append", default=[],
                        metavar="NAME=VALUE", help="override one parameter (repeatable)")
    parser.add_argument("--seed", type=int, default=None, help="random seed of the filter")
    parser.add_argument("--out", type=Path, default=None,
                        help="record outputs into this MCAP bag folder [<bag>_out]")
    parser.add_argument("--no-record", action="store_true", help="do not write an output bag")
    parser.add_argument("--progress", action="store_true",
                        help="show the progress bar even when stderr is not a terminal")
    parser.add_argument("--node", choices=("fastslam", "people_tracker"), default="fastslam",
                        help="the node to replay the bag through [fastslam]")
    args = parser.parse_args(argv)
    try:
        params = dict(parse_assignment(text) for text in args.assignments)
    except ValueError as error:
        parser.error(str(error))
    if args.seed is not None:
        params["seed"] = args.seed
    out = None if args.no_record else (args.out or args.bag.with_name(args.bag.name + "_out"))
    try:
        replay = replay_bag
        if args.node == "people_tracker":
            from fastslam_ros.tools.people_replay import replay_people_bag as replay
        result = replay(args.bag, params, args.params, out,
                        progress=args.progress or sys.stderr.isatty())
    except (FileNotFoundError, SchemaError, ValueError, OSError) as error:
        print(f"fastslam-replay: {error}", file=sys.stderr)
        return 1
    print("\n".join(summary_lines(result)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
