# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""CLEAR MOT and the people pipeline: hand-counted frames, and sim -> replay -> eval."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from fastslam_ros.tools.evaluation import people_eval
from fastslam_ros.tools.bags.bag_schema import bag_topics
from fastslam_ros.people import OccupancyMap
from fastslam_ros.people.detection import Scan
from fastslam_ros.tools.evaluation.people_eval import (Frame, LaserView, clear_mot,
                                                      hidden_by_people, in_view)


def frame(ids, positions) -> Frame:
    return Frame(0.0, np.asarray(ids), np.asarray(positions, dtype=float).reshape(-1, 2))


def test_clear_mot_counts_by_hand():
    truth = [frame([1, 2], [[0, 0], [5, 0]]), frame([1, 2], [[0, 0], [5, 0]]),
             frame([1, 2], [[0, 0], [5, 0]]), frame([1], [[0, 0]])]
    estimates = [frame([10, 20], [[0.1, 0], [5, 0.2]]),      # two hits
                 frame([11, 20], [[0.0, 0.1], [9, 9]]),      # a switch 10 -> 11, a miss, a FP
                 frame([11], [[0.0, 0.3]]),                   # a hit, a miss
                 frame([], [])]                               # a miss
    result = clear_mot(truth, estimates)
    assert result["truth_count"] == 7
    assert result["matches"] == 4
    assert result["misses"] == 3
    assert result["false_positives"] == 1
    assert result["id_switches"] == 1
    assert result["mota"] == pytest.approx(1 - (3 + 1 + 1) / 7)
    assert result["motp"] == pytest.approx((0.1 + 0.2 + 0.1 + 0.3) / 4)


def test_switch_gaps_are_the_time_between_a_persons_two_matches():
    # person 1: matched by 10 at t 0, unmatched until t 1.5, then by 11 (gap 1.5 s: short);
    # person 2: matched by 20 at t 0, unmatched until t 3, then by 21 (gap 3 s: long)
    truth, estimates = [], []
    for t in np.arange(0.0, 3.01, 0.5):
        truth.append(Frame(float(t), np.array([1, 2]), np.array([[0.0, 0.0], [5.0, 0.0]])))
        ids = [10, 20] if t == 0.0 else [11] if 1.5 <= t < 3.0 else [11, 21] if t >= 3.0 else []
        spots = {10: [0, 0], 11: [0, 0], 20: [5, 0], 21: [5, 0]}
        estimates.append(Frame(float(t), np.array(ids, dtype=int),
                               np.array([spots[i] for i in ids], dtype=float).reshape(-1, 2)))
    result = clear_mot(truth, estimates)
    assert result["id_switches"] == 2
    assert result["id_switch_gaps"] == pytest.approx([1.5, 3.0])
    assert result["id_switches_short_gap"] == 1


def test_a_kept_match_is_not_a_switch_when_another_track_comes_closer():
    truth = [frame([1], [[0, 0]]), frame([1], [[0, 0]])]
    estimates = [frame([10], [[0.4, 0]]), frame([10, 11], [[0.4, 0], [0.0, 0.0]])]
    result = clear_mot(truth, estimates)
    assert result["id_switches"] == 0
    assert result["false_positives"] == 1


def test_hidden_by_people():
    pose = np.array([0.0, 0.0, 0.0])
    hidden = hidden_by_people(pose, np.array([[2.0, 0.0], [4.0, 0.1], [4.0, 3.0]]))
    np.testing.assert_array_equal(hidden, [False, True, False])


def test_a_track_of_a_person_just_out_of_view_is_neither_a_hit_nor_a_false_positive():
    # a 270-degree laser facing +x in the middle of an empty 10 m room: person 1 ahead, person
    # 2 with its centre 0.04 rad behind the span's right edge; a track of each a few cm off
    # (person 2's inside the span) and one in view where nobody is
    walls = np.zeros((200, 200), bool)
    walls[[0, -1], :] = walls[:, [0, -1]] = True
    grid = OccupancyMap(walls, ~walls, 0.05)
    span = 1.5 * np.pi
    view = LaserView(12.0, Scan(np.zeros(540), -span / 2, span / 540))
    pose = np.array([5.0, 5.0, 0.0])

    def at(bearing: float, distance: float) -> np.ndarray:
        return pose[:2] + distance * np.array([np.cos(bearing), np.sin(bearing)])

    truth = Frame(0.0, np.array([1, 2]), np.array([at(0.3, 2.0), at(-span / 2 - 0.04, 2.0)]))
    tracks = Frame(0.0, np.array([10, 20, 30]),
                   np.array([at(0.32, 2.0), at(-span / 2 + 0.02, 2.0), at(1.5, 3.0)]),
                   np.ones(3))
    gt, kept = in_view(grid, pose, truth, tracks, view, 0.5)
    np.testing.assert_array_equal(gt.ids, [1])
    np.testing.assert_array_equal(kept.ids, [10, 30])
    result = clear_mot([gt], [kept])
    assert (result["matches"], result["false_positives"], result["misses"]) == (1, 1, 0)


def test_a_track_is_judged_by_the_view_of_its_nearest_person():
    # a laser at (5, 5) facing +x; a door jamb from x = 6.0 to 6.1 above y = 5.05: person 1 at
    # (7, 5) is in view, its track 0.15 m to the jamb's side is not (its own ray ends on the jamb
    # 1 m out); person 2 stands behind the jamb, its track 0.3 m off, behind the jamb too
    walls = np.zeros((200, 200), bool)
    walls[[0, -1], :] = walls[:, [0, -1]] = True
    walls[101:120, 120:122] = True                     # rows: y, columns: x (0.05 m cells)
    grid = OccupancyMap(walls, ~walls, 0.05)
    view = LaserView(12.0)
    pose = np.array([5.0, 5.0, 0.0])
    truth = Frame(0.0, np.array([1, 2]), np.array([[7.0, 5.0], [7.0, 5.8]]))
    tracks = Frame(0.0, np.array([10, 20]), np.array([[7.0, 5.15], [7.0, 5.5]]), np.ones(2))
    assert not people_eval.visible(grid, pose, tracks.positions, view).any()
    gt, kept = in_view(grid, pose, truth, tracks, view, 0.5)
    np.testing.assert_array_equal(gt.ids, [1])
    np.testing.assert_array_equal(kept.ids, [10])
    result = clear_mot([gt], [kept])
    assert (result["matches"], result["false_positives"], result["misses"]) == (1, 0, 0)


def test_simulate_replay_and_score_a_short_people_run(tmp_path):
    out = tmp_path / "demo"
    metrics = people_eval.run_people_demo(out, seed=1, duration=4.0)
    topics = bag_topics(out / "sim_people")
    assert {"/map", "/scan", "/odom", "/ground_truth/pose", "/ground_truth/people",
            "/initialpose"} <= set(topics)
    assert people_eval.is_people_run(bag_topics(out / "replay"))
    assert metrics["robot"]["raw"]["rmse"] < 0.1
    assert metrics["people"]["frames"] > 30
    assert (out / "result.png").exists()
    # docs/people_errors.py breaks the errors down from the same frames: its misses are the
    # evaluator's, and each false positive it finds falls in one of its three kinds
    spec = importlib.util.spec_from_file_location(
        "people_errors", Path(__file__).parents[1] / "docs" / "people_errors.py")
    people_errors = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(people_errors)
    found = people_errors.errors(str(out / "replay"))
    assert found["misses"] == metrics["people_unhidden"]["misses"]
    assert found["new_in_view"] <= found["misses"] and found["far"] <= found["misses"]
    assert found["false_positives"] == (found["near_a_person_left_out"] + found["within_0.75"]
                                        + found["far_from_everyone"])


@pytest.mark.parametrize("bias", [0.05, -0.1])
def test_simulated_yaw_rate_bias_turns_the_odometry_at_that_rate(bias):
    """``--yaw-rate-bias``: the odometry's heading drifts from the truth's by the bias times
    the time, on top of what the unbiased odometry drifts: its turn noise (0.05 rad/s for a
    0.02 s step: 0.001 rad a step, a random walk) and its 1 % turn-rate error."""
    from fastslam_ros.tools.simulation.people_sim import PeopleSimConfig, simulate_people
    configs = [PeopleSimConfig(duration=10.0, people=0, yaw_rate_bias=b) for b in (0.0, bias)]
    runs = [simulate_people(config) for config in configs]
    drift = [np.unwrap(run.odometry.poses[:, 2]) - np.unwrap(run.truth.poses[:, 2])
             for run in runs]
    elapsed = np.arange(len(drift[1])) / configs[1].odometry_rate
    np.testing.assert_array_equal(runs[0].truth.poses, runs[1].truth.poses)
    np.testing.assert_allclose(drift[1] - drift[0], bias * elapsed, atol=1e-9)
    steps = len(elapsed) - 1
    turned = np.abs(np.diff(np.unwrap(runs[0].truth.poses[:, 2]))).sum()
    assert abs(drift[0][-1]) < 4.0 * 0.001 * np.sqrt(steps) + 0.01 * turned


def test_simulated_yaw_rate_bias_must_be_finite():
    from fastslam_ros.tools.simulation.people_sim import PeopleSimConfig
    with pytest.raises(ValueError, match="yaw_rate_bias"):
        PeopleSimConfig(yaw_rate_bias=float("nan")).validate()
