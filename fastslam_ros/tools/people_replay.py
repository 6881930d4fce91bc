"""Replay a people bag through the real ``PeopleTrackerNode`` in-process (``fastslam-replay BAG
--node people_tracker``), as ``fastslam-replay`` does for the SLAM node.

``/map``, ``/initialpose``, ``/odom`` and ``/scan`` go in bag-time order to the node's callbacks
with its clock set to each message's bag time; every output, copies of the inputs and ground
truth, ``/tf`` and ``/tf_static``, and one ``/fastslam_replay/info`` message are recorded into
OUT for ``fastslam-eval``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from fastslam_ros.people_node import NODE_NAME, PeopleTrackerNode, parameter_specs
from fastslam_ros.tools.bag_schema import GROUND_TRUTH_POSE_TOPIC, ODOM_TOPIC
from fastslam_ros.tools.people_sim import (INITIAL_POSE_TOPIC, MAP_TOPIC, PEOPLE_TRUTH_TOPIC,
                                           SCAN_TOPIC)
from fastslam_ros.tools.replay import ReplayResult, ReplayTarget, replay_through

PEOPLE_TARGET = ReplayTarget(
    NODE_NAME, PeopleTrackerNode, parameter_specs(),
    lambda node: {MAP_TOPIC: node.on_map, INITIAL_POSE_TOPIC: node.on_initial_pose,
                  ODOM_TOPIC: node.on_odometry, SCAN_TOPIC: node.on_scan},
    (ODOM_TOPIC, SCAN_TOPIC),
    (MAP_TOPIC, SCAN_TOPIC, ODOM_TOPIC, GROUND_TRUTH_POSE_TOPIC, PEOPLE_TRUTH_TOPIC),
    SCAN_TOPIC, "scan_frame")


def replay_people_bag(bag_path: str | Path, params: dict[str, Any] | None = None,
                      params_file: str | Path | None = None, out_path: str | Path | None = None,
                      progress: bool = False, overwrite: bool = False,
                      remap: dict[str, str] | None = None) -> ReplayResult:
    """Feed the bag to a fresh ``PeopleTrackerNode`` and record its outputs into ``out_path``
    (arguments and errors as ``replay.replay_bag``)."""
    return replay_through(PEOPLE_TARGET, bag_path, params, params_file, out_path, progress,
                          overwrite, remap)
