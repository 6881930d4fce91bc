# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""End to end on real data: the first minutes of one MRCLAM robot, converted, replayed through
the node with the shipped ``config/mrclam.yaml`` and evaluated against Vicon."""
from __future__ import annotations

from fastslam_ros.tools.datasets import convert
from fastslam_ros.tools.benchmarks.benchmark import config_dir

DURATION = 120.0
"""Seconds of MRCLAM Dataset 6, robot 3 replayed (about 10 s of CPU)."""
ALIGNED_ATE_BOUND = 0.35
"""Bound (m) on the aligned ATE of the at-the-time estimate; dead reckoning is ~0.6 m here."""


def test_mrclam_first_minutes_end_to_end(dataset_dir, tmp_path):
    from fastslam_ros.tools.evaluation.evaluate import evaluate
    from fastslam_ros.tools.bags.replay import replay_bag

    bag = tmp_path / "mrclam6_r3"
    convert.convert("mrclam", dataset_dir("MRCLAM/MRCLAM_Dataset6"), bag, robot=3,
                    duration=DURATION)
    out = tmp_path / "out"
    result = replay_bag(bag, params={"association": "ml", "seed": 1},
                        params_file=config_dir() / "mrclam.yaml", out_path=out)
    assert result.stats["used_landmarks"] > 100
    metrics = evaluate(out, ground_truth_path=bag)
    estimate = metrics["estimate"]["aligned"]["rmse"]
    dead_reckoning = metrics["dead_reckoning"]["aligned"]["rmse"] if "dead_reckoning" in metrics \
        else None
    assert estimate < ALIGNED_ATE_BOUND, (estimate, dead_reckoning)
    assert metrics["final_path"]["aligned"]["rmse"] < ALIGNED_ATE_BOUND
    assert metrics["landmarks"]["matched"] >= 5
