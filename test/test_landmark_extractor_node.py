# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""LandmarkExtractorNode with real rclpy, driven through its callbacks on a simulated clock:
its clouds carry the scan's exact header and the extractor's landmarks, fastslam_node uses them
as they are, bad input is counted and /diagnostics says what is wrong; the launch file starts
both nodes."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticStatus
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rclpy.time import Time
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Header

from fastslam_ros import ros_io
from fastslam_ros.extractor import ExtractorSettings, extract_landmarks
from fastslam_ros.extractor_io import EXTRACTED_CLOUD_DTYPE, read_scan
from fastslam_ros.landmark_extractor_node import LandmarkExtractorNode, parameter_specs
from fastslam_ros.node import FastSLAMNode
from fastslam_ros.node_parameters import ParameterError
from fastslam_ros.tools.bags.bag_schema import cloud_to_arrays
from fastslam_ros.tools.bags.in_process import in_process
from test_extractor import ANGLE_MIN, INCREMENT, cast
from test_launch import launch_stand_ins  # noqa: F401 - a fixture

REPO = Path(__file__).resolve().parents[1]
START = 1_700_000_000.0
POLES = [(4.0, 1.0, 0.12), (7.0, -2.0, 0.2)]


def make_node(context, **params) -> LandmarkExtractorNode:
    overrides = [Parameter(k, value=v) for k, v in {"use_sim_time": True, **params}.items()]
    node = in_process(LandmarkExtractorNode)(context=context, parameter_overrides=overrides,
                                             enable_rosout=False)
    return node


def scan_message(stamp: float, ranges: np.ndarray, intensities=(), frame: str = "laser"
                 ) -> LaserScan:
    seconds = math.floor(stamp)
    header = Header(stamp=TimeMsg(sec=int(seconds), nanosec=int(round((stamp - seconds) * 1e9))),
                    frame_id=frame)
    return LaserScan(header=header, angle_min=ANGLE_MIN, angle_increment=INCREMENT,
                     angle_max=ANGLE_MIN + INCREMENT * (len(ranges) - 1), range_min=0.05,
                     range_max=30.0, ranges=np.asarray(ranges, np.float32).tolist(),
                     intensities=np.asarray(intensities, np.float32).tolist())


def deliver(node, msg, arrival: float) -> None:
    node.get_clock().set_ros_time_override(Time(nanoseconds=round(arrival * 1e9)))
    (node.on_odometry if isinstance(msg, Odometry) else
     getattr(node, "on_scan", None) or node.on_landmarks)(msg)


class Recorder:
    def __init__(self, node) -> None:
        self.messages: dict[str, list] = {}
        node.output_listeners.append(self)

    def __call__(self, topic: str, msg) -> None:
        self.messages.setdefault(topic, []).append(msg)

    def last_status(self) -> DiagnosticStatus:
        return self.messages["/diagnostics"][-1].status[0]


def test_cloud_has_the_scans_exact_header_and_the_extractors_landmarks(context):
    node = make_node(context)
    recorder = Recorder(node)
    try:
        ranges = cast(POLES)
        msg = scan_message(START + 0.123456789, ranges)
        deliver(node, msg, START + 0.2)
        (cloud,) = recorder.messages["/landmarks"]
        assert cloud.header.stamp == msg.header.stamp
        assert cloud.header.frame_id == "laser"
        assert [(f.name, f.datatype) for f in cloud.fields] == [
            ("x", 7), ("y", 7), ("z", 7), ("id", 5), ("radius", 7), ("intensity", 7)]
        points = np.frombuffer(bytes(cloud.data), EXTRACTED_CLOUD_DTYPE)
        expected = extract_landmarks(read_scan(msg), ExtractorSettings())
        assert len(points) == 2 and np.all(points["id"] == -1)
        assert points["x"] == pytest.approx(expected.landmarks.x.astype(np.float32))
        assert sorted(zip(points["x"].round(3), points["y"].round(3))) == pytest.approx(
            sorted((x, y) for x, y, _ in POLES), abs=1e-3)
        assert sorted(points["radius"]) == pytest.approx([0.12, 0.2], abs=1e-5)
        # What fastslam_node and the tools read from it.
        read = ros_io.read_landmark_cloud(cloud)
        assert np.all(read.ids == -1) and len(read.x) == 2
        assert set(cloud_to_arrays(cloud)) >= {"x", "y", "id", "radius", "intensity"}
        assert node.stats["used_scan"] == 1 and node.stats["landmarks"] == 2
        node.flush()
        markers = recorder.messages["/landmark_extractor/markers"][-1].markers
        assert markers[0].action == markers[0].DELETEALL and len(markers) == 3
        assert recorder.last_status().level == DiagnosticStatus.OK
    finally:
        node.destroy_node()


def test_fastslam_node_uses_the_clouds_unchanged(context):
    extractor = make_node(context)
    slam = in_process(FastSLAMNode)(context=context, enable_rosout=False, parameter_overrides=[
        Parameter("use_sim_time", value=True), Parameter("seed", value=1),
        Parameter("num_particles", value=20), Parameter("sensor_frame", value="laser")])
    extractor.output_listeners.append(
        lambda topic, msg: deliver(slam, msg, START + 0.5) if topic == "/landmarks" else None)
    try:
        for step in range(40):
            stamp = START + 0.05 * step
            odometry = Odometry(header=Header(stamp=ros_io.seconds_to_stamp(stamp),
                                              frame_id="odom"), child_frame_id="base_link")
            odometry.pose.pose = ros_io.pose_msg((0.0, 0.0, 0.0))
            deliver(slam, odometry, stamp)
            if step % 4 == 2:
                deliver(extractor, scan_message(stamp, cast(POLES)), stamp)
        slam.flush()
        assert extractor.stats["used_scan"] == 10
        assert slam.stats["used_landmarks"] >= 9
        assert not any(v for k, v in slam.stats.items() if k.startswith("dropped_"))
    finally:
        extractor.destroy_node()
        slam.destroy_node()


def test_bad_parameters_stop_the_node_naming_them(context):
    with pytest.raises(ParameterError, match="segment_jump"):
        make_node(context, segment_jump=-1.0)
    with pytest.raises(ParameterError, match="min_diameter"):
        make_node(context, min_diameter=0.7, max_diameter=0.5)
    with pytest.raises(ParameterError, match="detector"):
        make_node(context, detector="lines")
    with pytest.raises(ParameterError, match="unknown parameter 'segment_jmp'"):
        make_node(context, segment_jmp=0.2)


def test_bad_scans_are_dropped_counted_and_reported(context):
    beams = len(cast(POLES))
    node = make_node(context, scan_frame="laser", max_beams_per_scan=beams)
    recorder = Recorder(node)
    try:
        deliver(node, scan_message(START, cast(POLES)), START)
        short = scan_message(START + 0.1, cast(POLES), intensities=[1.0, 2.0])
        deliver(node, short, START + 0.1)
        deliver(node, scan_message(START + 0.2, cast(POLES), frame="base"), START + 0.2)
        deliver(node, scan_message(START + 0.3, []), START + 0.3)
        deliver(node, scan_message(START, cast(POLES)), START + 0.4)   # stamp repeated
        deliver(node, scan_message(START + 0.5, np.append(cast(POLES), 1.0)), START + 0.5)
        crossed = scan_message(START + 0.6, cast(POLES))
        crossed.range_min, crossed.range_max = 5.0, 1.0
        deliver(node, crossed, START + 0.6)
        assert node.stats["dropped_malformed_scan"] == 3
        assert node.stats["dropped_oversized_scan"] == 1
        assert node.stats["dropped_wrong_frame"] == 1
        assert node.stats["dropped_duplicate_stamp"] == 1
        assert len(recorder.messages["/landmarks"]) == 1
        node.flush()
        status = recorder.last_status()
        assert status.level == DiagnosticStatus.WARN and "6 input(s) dropped" in status.message
        values = {v.key: v.value for v in status.values}
        assert values["dropped_malformed_scan"] == "3"
    finally:
        node.destroy_node()


def test_with_scan_frame_empty_a_scan_in_another_frame_than_the_first_is_dropped(context):
    node = make_node(context)
    recorder = Recorder(node)
    try:
        deliver(node, scan_message(START, cast(POLES), frame="laser"), START)
        deliver(node, scan_message(START + 0.1, cast(POLES), frame="base"), START + 0.1)
        deliver(node, scan_message(START + 0.2, cast(POLES), frame="laser"), START + 0.2)
        assert node.stats["dropped_wrong_frame"] == 1
        assert [m.header.frame_id for m in recorder.messages["/landmarks"]] == ["laser"] * 2
    finally:
        node.destroy_node()


def test_diagnostics_warn_before_scans_and_when_reflectors_have_no_intensities(context):
    node = make_node(context, detector="reflectors")
    recorder = Recorder(node)
    try:
        node.flush()
        assert "waiting for a usable scan" in recorder.last_status().message
        deliver(node, scan_message(START, cast(POLES)), START)
        node.flush()
        status = recorder.last_status()
        assert status.level == DiagnosticStatus.WARN and "intensities" in status.message
    finally:
        node.destroy_node()


def test_config_file_and_docs_list_every_parameter_at_its_default():
    values = yaml.safe_load((REPO / "config" / "landmark_extractor.yaml").read_text())
    values = values["/**"]["ros__parameters"]
    docs = (REPO / "docs" / "extractor.md").read_text()
    specs = parameter_specs()
    assert set(values) == set(specs)
    for name, (default, _) in specs.items():
        assert values[name] == default, name
        assert f"| `{name}` | {default!r} |" in docs, name


def test_laser_launch_file_starts_the_extractor_and_the_slam_node(launch_stand_ins):  # noqa: F811
    import runpy
    path = REPO / "launch" / "laser_slam.launch.py"
    description = runpy.run_path(str(path))["generate_launch_description"]()
    entities = description.args[0]
    arguments = {e.args[0]: e.kwargs for e in entities
                 if type(e).__name__ == "DeclareLaunchArgument"}
    nodes = {e.kwargs["name"]: e.kwargs for e in entities if type(e).__name__ == "Node"}
    assert set(nodes) == {"landmark_extractor", "fastslam"}
    assert set(re.findall(r"(\w+):=", path.read_text())) <= set(arguments)
    assert nodes["landmark_extractor"]["executable"] == "landmark_extractor_node"
    assert nodes["fastslam"]["executable"] == "fastslam_node"
    setup = (REPO / "setup.py").read_text()
    assert '"landmark_extractor_node = fastslam_ros.landmark_extractor_node:main"' in setup
    for node in nodes.values():
        params_file = node["parameters"][0]
        assert params_file.args[0] in arguments
    # The extractor's scan (and odometry) input is remappable; its landmarks go to the SLAM
    # node's input.
    remaps = {topic: value.args[0] for topic, value in nodes["landmark_extractor"]["remappings"]}
    assert remaps == {"scan": "scan_topic", "odom": "odom_topic"}
    remaps = {topic: value.args[0] for topic, value in nodes["fastslam"]["remappings"]}
    assert remaps == {"odom": "odom_topic"}
    extractor_config = arguments["extractor_params_file"]["default_value"].args[0]
    assert extractor_config[1:] == ["config", "landmark_extractor.yaml"]


def test_console_node_help_and_bad_parameter_file(capsys, tmp_path):
    from fastslam_ros.landmark_extractor_node import main
    with pytest.raises(SystemExit) as exit_info:
        main(["landmark_extractor_node", "--help"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out.startswith("usage: landmark_extractor_node")
    bad = tmp_path / "bad.yaml"
    bad.write_text("landmark_extractor:\n  ros__parameters: [1, 2\n")
    assert main(["landmark_extractor_node", "--ros-args", "--params-file", str(bad)]) == 2
    assert "bad.yaml" in capsys.readouterr().err
