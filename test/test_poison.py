# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""fastslam-poison against the nodes: every fault class it writes is dropped and counted, and
the poisoned bag replays to the clean bag's outputs, message for message (fault injection)."""
from __future__ import annotations

import pytest
from rosbags.highlevel import AnyReader

from fastslam_ros.tools.bags import poison, replay
from fastslam_ros.tools.bags.bag_schema import TYPESTORE
from fastslam_ros.tools.simulation import sim

SLAM_OUTPUTS = ("/fastslam/pose", "/fastslam/map_cloud")
CASES = {  # bag -> (fastslam-sim arguments, replay, its remap, the topics fed, the outputs)
    "landmarks": (["--duration", "20", "--seed", "2"], replay.replay_bag, None,
                  ("/odom", "/landmarks"), SLAM_OUTPUTS),
    "people": (["--scenario", "people", "--legs", "--duration", "12", "--seed", "2"],
               replay.replay_people_bag, None, ("/odom", "/scan"),
               ("/people_tracker/pose", "/people_tracker/people")),
    "laser, through the extractor": (["--laser", "--duration", "20", "--seed", "2"],
                                     replay.replay_bag, {"/landmarks": "/hidden"},
                                     ("/odom", "/scan"), SLAM_OUTPUTS + ("/landmarks",)),
}


def _raw(path, topics) -> dict[str, list[tuple[int, bytes]]]:
    """(log time, serialized bytes) of every message on ``topics``."""
    found: dict[str, list[tuple[int, bytes]]] = {topic: [] for topic in topics}
    with AnyReader([path], default_typestore=TYPESTORE) as reader:
        wanted = [c for c in reader.connections if c.topic in found]
        for connection, stamp, raw in reader.messages(connections=wanted):
            found[connection.topic].append((stamp, bytes(raw)))
    return found


@pytest.mark.parametrize("kind", CASES)
def test_a_poisoned_bag_replays_to_the_clean_outputs_with_every_fault_counted(tmp_path, kind):
    arguments, replay_function, remap, fed, outputs = CASES[kind]
    bag = tmp_path / "clean"
    assert sim.main(["--out", str(bag), *arguments]) == 0
    params = tmp_path / "clean.yaml"
    counts = poison.poison_bag(bag, tmp_path / "poisoned", rate=3.0, seed=1)
    assert all(count >= 1 for count in counts.values()), counts
    assert any(name.startswith("scan") for name in counts) == ("/scan" in fed)
    assert any(name.startswith("map") for name in counts) == (kind == "people")

    clean = replay_function(bag, {"seed": 1}, params, tmp_path / "clean_out", remap=remap)
    poisoned = replay_function(tmp_path / "poisoned", {"seed": 1}, params,
                               tmp_path / "poisoned_out", remap=remap)
    assert not any(v for k, v in clean.stats.items() if "dropped_" in k)
    # Every added message on a topic the replay feeds (odometry, clouds, scans; a people bag's
    # map and initial pose too) reaches each node that reads the topic and is dropped; an
    # amended cloud ("point ...") is a valid message that loses its bad points. The extractor
    # makes no cloud of a bad scan.
    added = {topic: sum(n for name, n in counts.items() if name.split()[0] == prefix)
             for prefix, topic in (("odometry", "odom"), ("cloud", "landmarks"),
                                   ("scan", "scan"), ("map", "map"),
                                   ("initialpose", "initialpose"))}
    if "/landmarks" not in fed:
        added["landmarks"] = 0
    for key in poisoned.stats:
        if "received_" in key:
            topic = key.rsplit("received_", 1)[1]
            assert poisoned.stats[key] - clean.stats[key] == added.get(topic, 0), key
        if "used_" in key:   # received, and none of them used: every one dropped
            assert poisoned.stats[key] == clean.stats[key], key
    assert any(v for k, v in poisoned.stats.items() if "dropped_" in k)
    clean_outputs = _raw(tmp_path / "clean_out", outputs)
    assert all(clean_outputs.values())
    assert _raw(tmp_path / "poisoned_out", outputs) == clean_outputs
