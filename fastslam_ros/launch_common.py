# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The launch description both nodes' launch files share (``launch/*.launch.py``).

One node with its parameter file (``params_file``, the installed config by default), a
``namespace``, the clock (``use_sim_time``) and one ``TOPIC_topic`` argument per input topic,
remapped from the node's name for it. Imported only by ``ros2 launch`` (needs the ROS 2
``launch`` and ``launch_ros`` packages, which nothing else in the package uses).
"""
from __future__ import annotations

PACKAGE = "fastslam_ros"


def node_launch_description(executable: str, name: str, config: str,
                            topics: list[tuple[str, str]]):
    """A ``LaunchDescription`` of ``executable`` as node ``name`` with ``config/<config>``;
    ``topics``: (input topic, description) pairs, each remappable with ``<topic>_topic:=``."""
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument
    from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
    from launch_ros.actions import Node
    from launch_ros.parameter_descriptions import ParameterValue
    from launch_ros.substitutions import FindPackageShare

    arguments = [
        DeclareLaunchArgument(
            "params_file",
            default_value=PathJoinSubstitution([FindPackageShare(PACKAGE), "config", config]),
            description="YAML parameter file of the node"),
        DeclareLaunchArgument("namespace", default_value="",
                              description="Namespace of the node and its relative topics"),
        DeclareLaunchArgument("use_sim_time", default_value="false",
                              description="Use /clock (bag replay, simulation)"),
    ] + [DeclareLaunchArgument(f"{topic}_topic", default_value=topic, description=description)
         for topic, description in topics]
    node = Node(
        package=PACKAGE,
        executable=executable,
        name=name,
        namespace=LaunchConfiguration("namespace"),
        output="screen",
        parameters=[
            LaunchConfiguration("params_file"),
            {"use_sim_time": ParameterValue(LaunchConfiguration("use_sim_time"), value_type=bool)},
        ],
        remappings=[(topic, LaunchConfiguration(f"{topic}_topic")) for topic, _ in topics],
    )
    return LaunchDescription(arguments + [node])
