# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Replay a bag through the real ``FastSLAMNode`` in-process, fast and deterministic.

A bag with ``/scan`` and no ``/landmarks`` runs the landmark extractor in-process ahead of the
node (``tools/bags/laser_replay.py``).

Every ``/odom`` and ``/landmarks`` message of the bag is read straight from its CDR bytes into
a look-alike object (``tools/bags/cdr.py``: the attributes the node's readers use), any other input
(``/initialpose``) into its rclpy message class, and handed, in bag-time order, to the node's
subscription callbacks; before each one the node's time is set to the message's bag time
(``set_node_time``, as ``use_sim_time`` with a clock would; ``tools/bags/in_process.py``).
Nothing goes through DDS (the node's context has discovery off: no other process sees it) and
nothing waits, so
a replay runs as fast as the filter allows and gives the same outputs as a live run at the
same times. Every message the node publishes is recorded into
OUT (MCAP) at the bag time of the input being processed, together with copies of the bag's
``/odom``, ``/landmarks`` and ground-truth topics and one ``/fastslam_replay/info`` message
(``std_msgs/String``, JSON: wall and CPU time, bag duration, real-time factor, node counters,
the parameters used), so OUT alone is enough for ``fastslam-eval``. OUT also holds ``/tf``
(map -> odom from the node, odom -> base_link from each odometry message) and ``/tf_static``
(base_link -> the sensor frame, plus the input bag's static transforms), so RViz and Foxglove
show it as they would a live robot. The outputs a replay writes most often (pose, transform,
particles, path, map cloud, map markers, diagnostics) are serialized directly, byte for byte as
rosbags writes them.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, TextIO

import rclpy
import yaml
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader, AnyReaderError
from std_msgs.msg import String

from fastslam_ros import node_console
from fastslam_ros.node_console import ParamsFileError
from fastslam_ros.node_start import warn_line
from fastslam_ros.node import (CORE_PARAMETERS, NODE_PARAMETERS, FastSLAMNode, ParameterError,
                               read_params_file)
from fastslam_ros.tools.bags.in_process import (create_node, existing_objects_frozen, in_process,
                                                isolated_context)
from fastslam_ros.tools import cli
from fastslam_ros.tools.bags.cdr import (read_odometry,
                                    read_point_cloud)
from fastslam_ros.output import check_output
from fastslam_ros.tools.bags.bag_schema import (GROUND_TRUTH_LANDMARKS_TOPIC,
                                                GROUND_TRUTH_POSE_TOPIC, INITIAL_POSE_TOPIC,
                                                LANDMARKS_TOPIC, MAP_TOPIC, ODOM_TOPIC,
                                                PEOPLE_TRUTH_TOPIC, REPLAY_INFO_TOPIC, SCAN_TOPIC,
                                                TF_STATIC_TOPIC, TYPESTORE, SchemaError,
                                                check_topic_types, open_writer, ros_message_class,
                                                transform_message)
from fastslam_ros.tools.bags.recorder import OutputRecorder, lean_writer

INPUT_TOPICS = (ODOM_TOPIC, LANDMARKS_TOPIC)
COPIED_TOPICS = (ODOM_TOPIC, LANDMARKS_TOPIC, GROUND_TRUTH_POSE_TOPIC,
                 GROUND_TRUTH_LANDMARKS_TOPIC)
DIRECT_READERS = {"nav_msgs/msg/Odometry": read_odometry,
                  "sensor_msgs/msg/PointCloud2": read_point_cloud}
"""Input types read straight from their CDR bytes into look-alike objects (plain attributes,
which the node's readers accept as they accept rclpy messages): a bag holds about ten odometry
messages per reading, and a generic deserializer costs more than the filter's prediction. A
message they do not read (None) takes the generic path."""
PLAIN_TYPES = ("nav_msgs/msg/Odometry",)
"""Input types whose generic path is a rosbags message (a quarter of an rclpy message's cost)."""
UNDECODABLE_COUNTER = "dropped_undecodable"
"""Replay counter of bag messages whose bytes do not decode as their type."""
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
    saved_map: str = ""
    """What ``save_map`` wrote (the node's ``~/save_map`` response), or ''."""

    @property
    def real_time_factor(self) -> float:
        """Bag seconds processed per wall-clock second."""
        return self.bag_duration / self.wall_time if self.wall_time > 0 else math.inf


# ---------------------------------------------------------------- parameters


def load_params_file(path: str | Path, node_name: str = "/fastslam") -> dict[str, Any]:
    """The node's parameters from a ROS 2 parameter file, read as the node reads it (rclpy's
    parser, the sections that match ``node_name``); ParameterError (a ValueError) names the
    file: ParamsFileError when it cannot be read or is no parameter file."""
    return read_params_file(path, node_name)


def parse_assignment(text: str) -> tuple[str, Any]:
    """``name=value`` or, as ``ros2 run ... -p`` writes it, ``name:=value``, with a YAML value
    (``0.5`` float, ``100`` int, ``ml`` string); numbers that YAML 1.1 leaves as strings
    (``2e-4``) are read as floats."""
    separator = ":=" if ":=" in text else "="
    name, separator, value = text.partition(separator)
    if not separator or not name.strip():
        raise ValueError(f"expected name=value or name:=value, got {text!r}")
    try:
        parsed = yaml.safe_load(value)
    except yaml.YAMLError as error:
        raise ValueError(f"{name.strip()}: not a YAML value: {value!r} "
                         f"({' '.join(str(error).split()[:6])})") from None
    if isinstance(parsed, str):
        try:
            parsed = float(parsed)
        except ValueError:
            pass
    return name.strip(), parsed


def parse_remap(text: str) -> tuple[str, str]:
    """``FROM:=TO`` (the ``--remap`` syntax of ROS 2): the bag's topic FROM is read as TO."""
    source, separator, target = text.partition(":=")
    if not separator or not source.strip() or not target.strip():
        raise ValueError(f"expected FROM:=TO, got {text!r}")
    return _absolute(source.strip()), _absolute(target.strip())


def _absolute(topic: str) -> str:
    return topic if topic.startswith("/") else "/" + topic


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


@dataclass(frozen=True)
class ReplayTarget:
    """What a replay needs to know of a node besides the node itself."""

    node_name: str
    """The node's name: the sections of a parameter file that apply."""
    make_node: Callable[..., Any]
    """The in-process node class (``in_process.in_process``; keyword arguments of
    ``rclpy.node.Node``)."""
    specs: dict[str, tuple[Any, Any]]
    """{name: (default, spec)} of the node's parameters."""
    callbacks: Callable[[Any], dict[str, Callable[[Any], None]]]
    """{bag topic: the node's callback} for a node."""
    required_topics: tuple[str, ...]
    copied_topics: tuple[str, ...]
    """Inputs and ground truth copied into the output bag."""
    sensor_topic: str
    """Input whose first message's frame is the sensor frame (for ``/tf_static``)."""
    sensor_frame_parameter: str
    """Parameter naming the sensor frame ('' takes it from the first ``sensor_topic`` message)."""
    recorded_params: tuple[str, ...] = ()
    """Parameters always written into the info message (as well as those given)."""
    params_from_file: Callable[[str | Path], dict[str, Any]] | None = None
    """Reads the parameters from a file (None: its ``node_name`` sections)."""


SLAM_TARGET = ReplayTarget(
    "fastslam", in_process(FastSLAMNode, lean=True), {**CORE_PARAMETERS, **NODE_PARAMETERS},
    lambda node: {ODOM_TOPIC: node.on_odometry, LANDMARKS_TOPIC: node.on_landmarks,
                  INITIAL_POSE_TOPIC: node.on_initial_pose},
    INPUT_TOPICS, COPIED_TOPICS, LANDMARKS_TOPIC, "sensor_frame",
    # The association is always recorded: the evaluation matches landmarks by it.
    ("algorithm", "association"))


def people_target() -> ReplayTarget:
    """The people tracker's target (its node is imported only when a people bag is replayed)."""
    from fastslam_ros.people_node import NODE_NAME, PeopleTrackerNode, parameter_specs
    return ReplayTarget(
        NODE_NAME, in_process(PeopleTrackerNode, lean=True), parameter_specs(),
        lambda node: {MAP_TOPIC: node.on_map, INITIAL_POSE_TOPIC: node.on_initial_pose,
                      ODOM_TOPIC: node.on_odometry, SCAN_TOPIC: node.on_scan},
        (ODOM_TOPIC, SCAN_TOPIC),
        (MAP_TOPIC, SCAN_TOPIC, ODOM_TOPIC, GROUND_TRUTH_POSE_TOPIC, PEOPLE_TRUTH_TOPIC),
        SCAN_TOPIC, "scan_frame")


def replay_bag(bag_path: str | Path, params: dict[str, Any] | None = None,
               params_file: str | Path | None = None, out_path: str | Path | None = None,
               progress: bool = False, overwrite: bool = False,
               remap: dict[str, str] | None = None,
               save_map: str | Path | None = None) -> ReplayResult:
    """Feed the bag's ``/odom`` and ``/landmarks`` to a fresh ``FastSLAMNode``; record outputs.

    ``params`` override ``params_file``; set ``seed`` in them for a reproducible run. ``remap``
    reads a bag topic under another name (``{"/wheel/odom": "/odom"}``). Raises
    ``FileNotFoundError`` / ``SchemaError`` for a missing or unreadable bag or missing topics,
    ``ValueError`` for bad parameters (the message names the parameter), ``FileExistsError``
    for an output that exists (without ``overwrite``, or that is not a bag, or an input).
    ``save_map``: at the end, write the map as ``~/save_map`` does (refined) to this file (not
    replacing one without ``overwrite``); ``ReplayResult.saved_map`` says what was written.
    """
    return replay_through(SLAM_TARGET, bag_path, params, params_file, out_path, progress,
                          overwrite, remap, save_map)


def replay_people_bag(bag_path: str | Path, params: dict[str, Any] | None = None,
                      params_file: str | Path | None = None, out_path: str | Path | None = None,
                      progress: bool = False, overwrite: bool = False,
                      remap: dict[str, str] | None = None) -> ReplayResult:
    """Feed a people bag (``/map``, ``/initialpose``, ``/odom``, ``/scan``) to a fresh
    ``PeopleTrackerNode`` and record its outputs (arguments and errors as ``replay_bag``)."""
    return replay_through(people_target(), bag_path, params, params_file, out_path, progress,
                          overwrite, remap)


def replay_through(target: ReplayTarget, bag_path: str | Path,
                   params: dict[str, Any] | None = None, params_file: str | Path | None = None,
                   out_path: str | Path | None = None, progress: bool = False,
                   overwrite: bool = False, remap: dict[str, str] | None = None,
                   save_map: str | Path | None = None) -> ReplayResult:
    """``replay_bag`` for the node ``target`` describes (``save_map``: fastslam only)."""
    bag_path = Path(bag_path)
    inputs = [bag_path] + ([Path(params_file)] if params_file else [])
    if out_path is not None:
        check_output(out_path, overwrite, "bag", inputs)  # before any work
    if save_map is not None:
        if target.node_name != SLAM_TARGET.node_name:
            raise ValueError("save_map: only the fastslam node saves a map")
        check_output(save_map, overwrite, "file", inputs)
    if target is SLAM_TARGET and _laser_only(bag_path, _topic_names(remap or {})):
        from fastslam_ros.tools.bags.laser_replay import laser_target  # the extractor ahead
        target = laser_target(SLAM_TARGET)
    merged = {}
    if params_file:
        merged = target.params_from_file(params_file) if target.params_from_file \
            else load_params_file(params_file, f"/{target.node_name}")
    merged.update(params or {})
    context = isolated_context()  # invisible to the robot's ROS graph
    with ExitStack() as cleanup:
        cleanup.callback(rclpy.try_shutdown, context=context)
        topics = _topic_names(remap or {})
        # The node class's methods name the topics it reads (before the node exists).
        read = (*target.callbacks(target.make_node), TF_STATIC_TOPIC)
        reader = cleanup.enter_context(_open_input(bag_path, topics, target.required_topics,
                                                   read))
        node = create_node(target.make_node, context, merged, target.specs)
        cleanup.callback(node.destroy_node)
        used_params = {name: node.get_parameter(name).value
                       for name in sorted(set(merged) | set(target.recorded_params))}
        recorder = None
        if out_path is not None:
            writer = cleanup.enter_context(open_writer(out_path, "mcap", overwrite, inputs,
                                                       wrap=lean_writer))
            recorder = OutputRecorder(writer)
            node.output_listeners.append(recorder.record)
            _record_static_transforms(node, reader, recorder, topics, target)
        start, start_cpu = time.perf_counter(), time.process_time()
        with existing_objects_frozen():
            done, duration = _feed(node, reader, recorder, progress, topics, target)
        result = ReplayResult(dict(node.stats), time.perf_counter() - start, duration,
                              Path(out_path) if out_path is not None else None, used_params,
                              time.process_time() - start_cpu)
        if save_map is not None:
            result.saved_map = node.save_map(save_map, overwrite, inputs)
        if recorder is not None:
            info = {"bag": str(bag_path), "node": target.node_name,
                    "wall_time": result.wall_time, "cpu_time": result.cpu_time,
                    "bag_duration": duration, "real_time_factor": result.real_time_factor,
                    "messages": done, "stats": result.stats, "params": used_params}
            recorder.record(REPLAY_INFO_TOPIC, String(data=json.dumps(info)))
        return result


TopicOf = Callable[[Any], str]
"""The name under which a bag connection is read."""


def _topic_names(remap: dict[str, str]) -> TopicOf:
    """Read each bag topic under its ``--remap`` name, or its own."""
    return lambda connection: remap.get(connection.topic, connection.topic)


def _laser_only(bag_path: Path, topic_of: TopicOf) -> bool:
    """Whether the bag has ``/scan`` but no ``/landmarks`` (False when it cannot be read)."""
    try:
        with AnyReader([bag_path], default_typestore=TYPESTORE) as reader:
            topics = {topic_of(c) for c in reader.connections}
    except (AnyReaderError, OSError):
        return False
    return SCAN_TOPIC in topics and LANDMARKS_TOPIC not in topics


@contextmanager
def _open_input(bag_path: Path, topic_of: TopicOf, required: tuple[str, ...],
                read: tuple[str, ...] = ()) -> Iterator[AnyReader]:
    """An open reader of a bag that has the required topics, and the topics ``read`` of their
    own types (SchemaError otherwise, naming the topics under their --remap names)."""
    if not bag_path.exists():
        raise FileNotFoundError(f"bag not found: {bag_path}")
    reader = AnyReader([bag_path], default_typestore=TYPESTORE)
    try:
        reader.open()
    except AnyReaderError as error:
        raise SchemaError(f"cannot read {bag_path}: {error}") from None
    try:
        topics = {topic_of(c) for c in reader.connections}
        missing = [topic for topic in required if topic not in topics]
        if missing:
            present = sorted(topic_of(c) + (f" (the bag's {c.topic}, remapped)"
                                            if topic_of(c) != c.topic else "")
                             for c in reader.connections)
            raise SchemaError(f"{bag_path}: missing topic(s) {', '.join(missing)} "
                              f"(has: {', '.join(present) or 'none'}; --remap FROM:=TO "
                              "reads a topic under another name)")
        check_topic_types({topic_of(c): c.msgtype for c in reader.connections}, bag_path, read)
        yield reader
    finally:
        reader.close()


def _record_static_transforms(node: Any, reader: AnyReader, recorder: OutputRecorder,
                              topic_of: TopicOf, target: ReplayTarget) -> None:
    """One latched ``/tf_static`` at the bag's start: base -> the sensor frame (the node's
    sensor pose; the frame named by its parameter or the first reading) and every static
    transform of the input bag."""
    transforms = []
    # An empty selection would mean "every connection" to rosbags.
    static = [c for c in reader.connections if topic_of(c) == TF_STATIC_TOPIC]
    for connection, _, raw in reader.messages(connections=static) if static else ():
        transforms += list(reader.deserialize(raw, connection.msgtype).transforms)
    base = node.get_parameter("base_frame").value
    sensor = node.get_parameter(target.sensor_frame_parameter).value
    if not sensor:  # the frame of the first reading that decodes
        clouds = [c for c in reader.connections if topic_of(c) == target.sensor_topic]
        for connection, _, raw in reader.messages(connections=clouds) if clouds else ():
            try:
                sensor = reader.deserialize(raw, connection.msgtype).header.frame_id
                break
            except AnyReaderError:
                continue
    known = {t.child_frame_id for t in transforms}
    recorder.stamp_ns = reader.start_time
    if sensor and sensor != base and sensor not in known:
        pose = [node.get_parameter(name).value for name in ("sensor_x", "sensor_y", "sensor_yaw")]
        transforms.append(transform_message(reader.start_time, base, sensor, pose))
    if transforms:
        recorder.tf(TF_STATIC_TOPIC, transforms)


def _feed(node: Any, reader: AnyReader, recorder: OutputRecorder | None, progress: bool,
          topic_of: TopicOf, target: ReplayTarget) -> tuple[int, float]:
    """Hand every input message to the node at its bag time, then flush; returns the number of
    inputs and the bag time they span (s)."""
    callbacks = target.callbacks(node)
    classes = {topic_of(c): ros_message_class(c.msgtype, topic_of(c)) for c in reader.connections
               if topic_of(c) in callbacks}
    wanted = [c for c in reader.connections if topic_of(c) in callbacks
              or (recorder is not None and topic_of(c) in target.copied_topics)]
    bar = ProgressBar(sum(c.msgcount for c in wanted if topic_of(c) in callbacks)) \
        if progress else None
    frames = (node.get_parameter("odom_frame").value, node.get_parameter("base_frame").value)
    first_ns = last_ns = None
    done = 0
    for connection, stamp_ns, raw in reader.messages(connections=wanted):
        topic = topic_of(connection)
        if recorder is not None:
            recorder.stamp_ns = stamp_ns
            if topic in target.copied_topics:
                recorder.copy(topic, connection.msgtype, stamp_ns, raw)
        if topic not in callbacks:
            continue
        first_ns = stamp_ns if first_ns is None else first_ns
        last_ns = stamp_ns
        node.set_node_time(stamp_ns)
        try:
            msg = _decode(reader, connection.msgtype, raw, classes[topic])
        except Exception as error:  # noqa: BLE001 - whatever the decoder raises on bad bytes
            _count_undecodable(node, topic, error)
            continue
        used_odometry = node.stats["used_odom"]
        callbacks[topic](msg)
        if recorder is not None and node.stats["used_odom"] > used_odometry:
            recorder.odometry_tf(msg, raw, *frames)  # only what the node did not drop
        done += 1
        if bar is not None:
            bar.update(done, (stamp_ns - first_ns) * 1e-9)
    node.flush()
    duration = (last_ns - first_ns) * 1e-9 if first_ns is not None else 0.0
    if bar is not None:
        bar.update(done, duration, final=True)
    return done, duration


def _decode(reader: AnyReader, msgtype: str, raw: bytes | memoryview, msg_class: Any) -> Any:
    """A bag message as the node's callback takes it (the fastest reader that applies)."""
    direct = DIRECT_READERS.get(msgtype)
    msg = direct(raw) if direct is not None else None
    if msg is None:
        if msgtype in PLAIN_TYPES:
            return reader.deserialize(raw, msgtype)
        return deserialize_message(bytes(raw), msg_class)
    return msg


def _count_undecodable(node: Any, topic: str, error: Exception) -> None:
    """Drop a bag message whose bytes do not decode (a live node never receives one: its
    middleware drops it), counted as ``dropped_undecodable`` in the node's counters."""
    node.stats.setdefault(UNDECODABLE_COUNTER, 0)
    node.stats[UNDECODABLE_COUNTER] += 1
    node._warn(UNDECODABLE_COUNTER, f"{topic}: message cannot be decoded ({error}) "
                                    f"[{UNDECODABLE_COUNTER}]")


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
    if result.saved_map:
        lines.append(f"map saved: {result.saved_map}")
    return lines


def build_parser() -> argparse.ArgumentParser:
    """The ``fastslam-replay`` argument parser."""
    parser = cli.parser("fastslam-replay", __doc__, first_paragraph=True)
    parser.add_argument("bag", type=Path, help="schema-v1 rosbag2 folder (mcap or sqlite3)")
    parser.add_argument("--params", type=Path, default=None,
                        help="ROS 2 parameter file (its /** and fastslam sections)")
    parser.add_argument("--set", "-p", dest="assignments", action="append", default=[],
                        metavar="NAME=VALUE",
                        help="override one parameter, as NAME=VALUE or NAME:=VALUE (repeatable)")
    parser.add_argument("--remap", "-r", dest="remaps", action="append", default=[],
                        metavar="FROM:=TO",
                        help="read the bag's topic FROM as TO, e.g. /wheel/odom:=/odom "
                             "(repeatable)")
    parser.add_argument("--seed", type=int, default=None, help="random seed of the filter")
    parser.add_argument("--out", type=Path, default=None,
                        help="record outputs into this MCAP bag folder (default: <bag>_out)")
    parser.add_argument("--no-record", action="store_true", help="do not write an output bag")
    parser.add_argument("--save-map", type=Path, default=None, metavar="FILE",
                        help="at the end, write the map as ~/save_map does (refined by the "
                             "least squares over the path; .csv: CSV, else YAML)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing output bag or map file (never another folder "
                             "or the input)")
    parser.add_argument("--progress", action="store_true",
                        help="show the progress bar even when stderr is not a terminal")
    parser.add_argument("--node", choices=("fastslam", "people_tracker"), default="fastslam",
                        help="the node to replay the bag through")
    return parser


@cli.interruptible("fastslam-replay")
def main(argv: list[str] | None = None) -> int:
    """``fastslam-replay``: replay a bag through the node (exit status as ``cli`` says)."""
    prog = "fastslam-replay"
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        params = dict(parse_assignment(text) for text in args.assignments)
        remap = dict(parse_remap(text) for text in args.remaps)
    except ValueError as error:
        parser.error(str(error))
    if args.seed is not None:
        params["seed"] = args.seed
    out = None if args.no_record else (args.out or args.bag.with_name(args.bag.name + "_out"))
    try:
        cli.input_bag(args.bag)
        if out is not None:
            cli.output_folder(out, "--out")
        if args.save_map is not None:
            if args.node != "fastslam":
                raise cli.UsageError("--save-map: only the fastslam node saves a map")
            cli.output_file(args.save_map, "--save-map")
        if args.params is not None:
            cli.input_file(args.params, "parameter file")
            node_console.read_params_file(args.params, f"/{args.node}", warn_line(prog))
    except cli.UsageError as error:
        return cli.fail(prog, error)
    except ParamsFileError as error:  # not a parameter file
        return cli.fail(prog, error, cli.EXIT_USAGE)
    except ParameterError as error:  # not one parameter of it applies
        return cli.fail(prog, error, cli.EXIT_FAILURE)
    try:
        target = people_target() if args.node == "people_tracker" else SLAM_TARGET
        result = replay_through(target, args.bag, params, args.params, out,
                                progress=args.progress or sys.stderr.isatty(),
                                overwrite=args.overwrite, remap=remap, save_map=args.save_map)
    except AnyReaderError as error:  # the bag opened, but a message of it cannot be read
        return cli.fail(prog, f"cannot read {args.bag}: {error}", cli.EXIT_FAILURE)
    except (SchemaError, ValueError, OSError) as error:
        return cli.fail(prog, error)
    print("\n".join(summary_lines(result)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
