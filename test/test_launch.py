# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The launch files, run against stand-ins of the ROS 2 launch packages (not installed here):
every argument their usage lines pass is declared, each topic argument remaps its input, and
the executable and parameter file they name exist."""
from __future__ import annotations

import re
import runpy
import sys
import types
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


class Recorded:
    """Stand-in of a launch class: keeps what it was built with."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


@pytest.fixture
def launch_stand_ins(monkeypatch):
    """``launch`` and ``launch_ros`` modules whose classes only record their arguments."""
    names = {"launch": ["LaunchDescription"], "launch.actions": ["DeclareLaunchArgument"],
             "launch.substitutions": ["LaunchConfiguration", "PathJoinSubstitution"],
             "launch_ros": [], "launch_ros.actions": ["Node"],
             "launch_ros.parameter_descriptions": ["ParameterValue"],
             "launch_ros.substitutions": ["FindPackageShare"]}
    for module_name, classes in names.items():
        module = types.ModuleType(module_name)
        for class_name in classes:
            setattr(module, class_name, type(class_name, (Recorded,), {}))
        monkeypatch.setitem(sys.modules, module_name, module)


def described(path: Path):
    """(declared arguments by name, the node) of a launch file's description."""
    description = runpy.run_path(str(path))["generate_launch_description"]()
    entities = description.args[0]
    arguments = {e.args[0]: e.kwargs for e in entities if type(e).__name__ ==
                 "DeclareLaunchArgument"}
    nodes = [e for e in entities if type(e).__name__ == "Node"]
    assert len(nodes) == 1 and len(entities) == len(arguments) + 1
    return arguments, nodes[0].kwargs


@pytest.mark.parametrize("launch_file, executable, config, inputs", [
    ("fastslam.launch.py", "fastslam_node", "fastslam.yaml", {"odom", "landmarks"}),
    ("people_tracker.launch.py", "people_tracker_node", "people_tracker.yaml",
     {"scan", "odom", "map", "initialpose"}),
])
def test_launch_file_declares_what_it_documents(launch_stand_ins, launch_file, executable,
                                               config, inputs):
    path = REPO / "launch" / launch_file
    arguments, node = described(path)
    usage = re.findall(r"(\w+):=", path.read_text())
    assert usage and set(usage) <= set(arguments)
    assert set(arguments) == {"params_file", "namespace", "use_sim_time"} | {
        f"{topic}_topic" for topic in inputs}
    assert all(kwargs["description"] for kwargs in arguments.values())
    default = arguments["params_file"]["default_value"].args[0]
    assert default[1:] == ["config", config] and (REPO / "config" / config).is_file()
    assert default[0].args == ("fastslam_ros",) and node["package"] == "fastslam_ros"
    # Each topic argument remaps the node's input of that name, default: the name itself.
    remaps = {topic: value.args[0] for topic, value in node["remappings"]}
    assert remaps == {topic: f"{topic}_topic" for topic in inputs}
    assert all(arguments[f"{topic}_topic"]["default_value"] == topic for topic in inputs)
    assert node["namespace"].args == ("namespace",)
    params_file, clock = node["parameters"]
    assert params_file.args == ("params_file",)
    assert clock["use_sim_time"].args[0].args == ("use_sim_time",)
    assert clock["use_sim_time"].kwargs == {"value_type": bool}
    setup = (REPO / "setup.py").read_text()
    assert f'"{executable} = fastslam_ros.' in setup and node["executable"] == executable
