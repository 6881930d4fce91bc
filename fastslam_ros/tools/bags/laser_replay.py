# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""``fastslam-replay`` of a laser bag: the landmark extractor runs in-process ahead of SLAM.

A bag with ``/scan`` and no ``/landmarks`` is replayed through ``LaserSLAMNode``: the SLAM
node with a ``LandmarkExtractorNode`` in the same context. Every scan goes to the extractor at
the SLAM node's time; each cloud it publishes goes to the SLAM node's ``on_landmarks`` as a
live ``landmarks`` subscription would hand it over, and, with every other output of the
extractor, to the replay's recorder; at the end its counters join the SLAM node's
(``extractor_<name>``). Odometry goes to the extractor too when it reads it
(``deskew_scans``, ``static_window``). Parameters of both nodes come from one file: its ``/**``
section, the ``landmark_extractor`` section (the extractor's parameters) and the ``fastslam``
section; a name both nodes declare (``max_range``, ``min_range``, ``markers_rate``) goes to
both.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from rclpy.exceptions import ParameterNotDeclaredException

from fastslam_ros.landmark_extractor_node import NODE_NAME as EXTRACTOR_NAME
from fastslam_ros.landmark_extractor_node import LandmarkExtractorNode, parameter_specs
from fastslam_ros.node import CORE_PARAMETERS, NODE_PARAMETERS, FastSLAMNode, read_params_file
from fastslam_ros.tools.bags.bag_schema import LANDMARKS_TOPIC, SCAN_TOPIC
from fastslam_ros.tools.bags.in_process import in_process

EXTRACTOR_PARAMETERS = parameter_specs()
SLAM_PARAMETERS = {**CORE_PARAMETERS, **NODE_PARAMETERS}


class LaserSLAMNode(in_process(FastSLAMNode, lean=True)):
    """fastslam_node with the landmark extractor ahead of it (``extractor``), both in-process,
    for a replay."""

    def __init__(self, *, parameter_overrides=(), **node_kwargs) -> None:
        """Both nodes; each gets the overrides it declares (``use_sim_time`` both, a name
        neither declares the SLAM node, which names it as unknown)."""
        slam = [p for p in parameter_overrides
                if p.name in SLAM_PARAMETERS or p.name not in EXTRACTOR_PARAMETERS]
        extractor = [p for p in parameter_overrides
                     if p.name in EXTRACTOR_PARAMETERS or p.name == "use_sim_time"]
        super().__init__(parameter_overrides=slam, **node_kwargs)
        try:
            self.extractor = in_process(LandmarkExtractorNode)(parameter_overrides=extractor,
                                                               **node_kwargs)
        except BaseException:
            FastSLAMNode.destroy_node(self)
            raise
        self.extractor.output_listeners.append(self._extracted)

    def _extracted(self, topic: str, msg: Any) -> None:
        """An output of the extractor: its clouds are this node's input; all are recorded."""
        if topic == "/landmarks":
            self.on_landmarks(msg)
        for listener in self.output_listeners:
            listener(topic, msg)

    def on_odometry(self, msg: Any) -> None:
        """Odometry of the bag: to the extractor first when it reads odometry (the scans it
        makes ready reach this node before the odometry does), then to SLAM."""
        if self.extractor.reads_odometry:
            self.extractor.on_odometry(msg)
        super().on_odometry(msg)

    def on_scan(self, msg: Any) -> None:
        """A scan of the bag: to the extractor (its cloud comes back through ``_extracted``)."""
        self.extractor.on_scan(msg)

    def set_node_time(self, nanoseconds: int) -> None:
        super().set_node_time(nanoseconds)
        self.extractor.set_node_time(nanoseconds)

    def get_parameter(self, name: str):
        """The SLAM node's parameter, else the extractor's."""
        try:
            return super().get_parameter(name)
        except ParameterNotDeclaredException:
            return self.extractor.get_parameter(name)

    def flush(self) -> None:
        """Flush both; the extractor's counters join this node's as ``extractor_<name>`` (the
        replay's summary and info message report them)."""
        self.extractor.flush()
        self.stats.update({f"extractor_{name}": count
                           for name, count in self.extractor.stats.items()})
        super().flush()

    def destroy_node(self) -> None:
        self.extractor.destroy_node()
        super().destroy_node()


def laser_params(path: str | Path) -> dict[str, Any]:
    """Both nodes' parameters from one file: the extractor's from its sections, then the SLAM
    node's (which win for a name both declare)."""
    extractor = read_params_file(path, f"/{EXTRACTOR_NAME}")
    values = {name: value for name, value in extractor.items() if name in EXTRACTOR_PARAMETERS}
    values.update(read_params_file(path, "/fastslam"))
    return values


def laser_target(slam_target: Any) -> Any:
    """The SLAM replay target (a ``replay.ReplayTarget``) for a bag with /scan instead of
    /landmarks."""
    return dataclasses.replace(
        slam_target, make_node=LaserSLAMNode,
        specs={**EXTRACTOR_PARAMETERS, **SLAM_PARAMETERS},
        callbacks=lambda node: {**slam_target.callbacks(node), SCAN_TOPIC: node.on_scan},
        required_topics=tuple(SCAN_TOPIC if topic == LANDMARKS_TOPIC else topic
                              for topic in slam_target.required_topics),
        copied_topics=(*slam_target.copied_topics, SCAN_TOPIC),
        sensor_topic=SCAN_TOPIC, params_from_file=laser_params)
