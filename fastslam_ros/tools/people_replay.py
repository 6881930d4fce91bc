"""Replay a people bag through the real ``PeopleTrackerNode`` in-process (``fastslam-replay BAG
--node people_tracker``), as ``fastslam-replay`` does for the SLAM node.

``/map``, ``/initialpose``, ``/odom`` and ``/scan`` go in bag-time order to the node's callbacks
with its clock set to each message's bag time; every output, copies of the inputs and ground
truth, and one ``/fastslam_replay/info`` message are recorded into OUT for ``fastslam-eval``.
"""
from __future__ import annotations

import json
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import rclpy
from rclpy.clock import ClockType
from rclpy.serialization import deserialize_message
from rclpy.time import Time
from rosbags.highlevel import AnyReader, AnyReaderError
from std_msgs.msg import String

from fastslam_ros.node import ParameterError
from fastslam_ros.people_node import PeopleTrackerNode, parameter_specs
from fastslam_ros.tools.bag_schema import (GROUND_TRUTH_POSE_TOPIC, ODOM_TOPIC, TYPESTORE,
                                           SchemaError, open_writer)
from fastslam_ros.tools.people_sim import (INITIAL_POSE_TOPIC, MAP_TOPIC, PEOPLE_TRUTH_TOPIC,
                                           SCAN_TOPIC)
from fastslam_ros.tools.replay import (INFO_TOPIC, OutputRecorder, ProgressBar, ReplayResult,
                                       isolated_context, load_params_file, node_parameters,
                                       ros_message_class)
from fastslam_ros.tools.output import check_output

INPUT_TOPICS = (MAP_TOPIC, INITIAL_POSE_TOPIC, ODOM_TOPIC, SCAN_TOPIC)
REQUIRED_TOPICS = (ODOM_TOPIC, SCAN_TOPIC)
COPIED_TOPICS = (MAP_TOPIC, SCAN_TOPIC, ODOM_TOPIC, GROUND_TRUTH_POSE_TOPIC, PEOPLE_TRUTH_TOPIC)


def replay_people_bag(bag_path: str | Path, params: dict[str, Any] | None = None,
                      params_file: str | Path | None = None, out_path: str | Path | None = None,
                      progress: bool = False, overwrite: bool = False) -> ReplayResult:
    """Feed the bag to a fresh ``PeopleTrackerNode`` and record its outputs into ``out_path``."""
    bag_path = Path(bag_path)
    inputs = [bag_path] + ([Path(params_file)] if params_file else [])
    if out_path is not None:
        check_output(out_path, overwrite, "bag", inputs)  # before any work
    merged = load_params_file(params_file, "/people_tracker") if params_file else {}
    merged.update(params or {})
    if not bag_path.exists():
        raise FileNotFoundError(f"bag not found: {bag_path}")
    context = isolated_context()  # invisible to the robot's ROS graph, as the SLAM replay
    with ExitStack() as cleanup:
        cleanup.callback(rclpy.try_shutdown, context=context)
        reader = AnyReader([bag_path], default_typestore=TYPESTORE)
        try:
            reader.open()
        except AnyReaderError as error:
            raise SchemaError(f"cannot read {bag_path}: {error}") from None
        cleanup.callback(reader.close)
        topics = {c.topic for c in reader.connections}
        missing = [t for t in REQUIRED_TOPICS if t not in topics]
        if missing:
            raise SchemaError(f"{bag_path}: missing topic(s) {', '.join(missing)}")
        try:
            node = PeopleTrackerNode(context=context, enable_rosout=False,
                                     parameter_overrides=node_parameters(merged,
                                                                         parameter_specs()))
        except ParameterError as error:
            raise ValueError(str(error)) from None
        cleanup.callback(node.destroy_node)
        node.publish_to_dds = False
        used_params = {name: node.get_parameter(name).value for name in sorted(merged)}
        recorder = None
        if out_path is not None:
            writer = open_writer(out_path, "mcap", overwrite, inputs)
            writer.open()
            cleanup.callback(writer.close)
            recorder = OutputRecorder(writer)
            node.output_listeners.append(recorder.record)
        callbacks = {MAP_TOPIC: node.on_map, INITIAL_POSE_TOPIC: node.on_initial_pose,
                     ODOM_TOPIC: node.on_odometry, SCAN_TOPIC: node.on_scan}
        classes = {c.topic: ros_message_class(c.msgtype) for c in reader.connections
                   if c.topic in INPUT_TOPICS}
        wanted = [c for c in reader.connections if c.topic in INPUT_TOPICS
                  or (recorder is not None and c.topic in COPIED_TOPICS)]
        bar = ProgressBar(sum(c.msgcount for c in wanted if c.topic in INPUT_TOPICS)) \
            if progress else None
        clock = node.get_clock()
        start, start_cpu = time.perf_counter(), time.process_time()
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
            callbacks[connection.topic](deserialize_message(bytes(raw),
                                                            classes[connection.topic]))
            done += 1
            if bar is not None:
                bar.update(done, (stamp_ns - first_ns) * 1e-9)
        node.flush()
        duration = (last_ns - first_ns) * 1e-9 if first_ns is not None else 0.0
        if bar is not None:
            bar.update(done, duration, final=True)
        result = ReplayResult(dict(node.stats), time.perf_counter() - start, duration,
                              Path(out_path) if out_path is not None else None, used_params,
                              time.process_time() - start_cpu)
        if recorder is not None:
            info = {"bag": str(bag_path), "node": "people_tracker",
                    "wall_time": result.wall_time, "cpu_time": result.cpu_time,
                    "bag_duration": duration, "real_time_factor": result.real_time_factor,
                    "messages": done, "stats": result.stats, "params": used_params}
            recorder.record(INFO_TOPIC, String(data=json.dumps(info)))
        return result
