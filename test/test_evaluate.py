# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Metric functions against hand-computed cases."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fastslam_ros.tools.bags.bag_schema import LandmarkSet, PoseSeries
from fastslam_ros.tools.evaluation.evaluate import (LandmarkEstimate, RunData, evaluate_run,
                                                    markdown_table, matches_by_id)
from fastslam_ros.tools.evaluation.metrics import (Transform2D, align_se2, error_stats,
                                                   evaluate_trajectory, interpolate_positions,
                                                   json_ready, landmark_metrics, match_landmarks,
                                                   nees_summary, ospa, truth_covers)

RNG = np.random.default_rng(7)


def test_alignment_removes_a_known_rotation_and_translation_exactly():
    reference = RNG.uniform(-50, 50, size=(40, 2))
    moved = Transform2D(yaw=0.7, translation=np.array([3.0, -12.0]))
    estimate = moved.apply(reference)
    alignment = align_se2(estimate, reference)
    np.testing.assert_allclose(alignment.apply(estimate), reference, atol=1e-10)
    assert alignment.yaw == pytest.approx(-0.7, abs=1e-12)


def test_alignment_is_the_least_squares_optimum_with_noise():
    reference = RNG.uniform(-20, 20, size=(60, 2))
    estimate = Transform2D(0.3, np.array([1.0, 2.0])).apply(reference) + RNG.normal(0, 0.2, (60, 2))
    best = align_se2(estimate, reference)
    cost = np.sum((best.apply(estimate) - reference) ** 2)
    for dyaw, dx in ((1e-3, 0.0), (-1e-3, 0.0), (0.0, 1e-3), (0.0, -1e-3)):
        nudged = Transform2D(best.yaw + dyaw, best.translation + (dx, 0.0))
        assert np.sum((nudged.apply(estimate) - reference) ** 2) > cost


def test_ate_of_a_constant_offset():
    stamps = np.arange(0.0, 10.0, 0.1)
    truth = PoseSeries(stamps, np.stack([stamps, np.sin(stamps), np.zeros_like(stamps)], axis=1))
    offset = np.array([3.0, 4.0])
    result = evaluate_trajectory(stamps, truth.poses[:, :2] + offset, truth)
    metrics = result.metrics()
    assert metrics["raw"]["rmse"] == pytest.approx(5.0)
    assert metrics["raw"]["max"] == pytest.approx(5.0)
    assert metrics["raw"]["final"] == pytest.approx(5.0)
    assert metrics["aligned"]["rmse"] == pytest.approx(0.0, abs=1e-9)
    assert metrics["samples"] == len(stamps)


def test_jumps_count_error_steps_beyond_the_threshold_not_the_motion():
    stamps = np.arange(0.0, 10.0)
    truth = PoseSeries(stamps, np.stack([3.0 * stamps, np.zeros(10), np.zeros(10)], axis=1))
    estimate = truth.poses[:, :2].copy()          # follows the truth, 3 m per step
    estimate[4] += (0.0, 2.0)                     # one excursion: out 2 m and back
    estimate[7:] += (0.4, 0.0)                    # one step under the threshold
    jumps = evaluate_trajectory(stamps, estimate, truth).metrics()["jumps"]
    assert jumps == {"threshold": 0.5, "count": 2, "max_step": pytest.approx(2.0)}
    table = markdown_table({"estimate": evaluate_trajectory(stamps, estimate, truth).metrics()})
    assert table.splitlines()[2].endswith("| 2 |")


def test_ground_truth_is_interpolated_but_not_across_gaps():
    stamps = np.array([0.0, 1.0, 2.0, 10.0])
    positions = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 4.0], [0.0, 0.0]])
    query = np.array([-0.5, 0.25, 1.5, 2.0, 5.0, 10.0, 11.0])
    poses = np.column_stack([positions, np.zeros(len(stamps))])
    values, valid = interpolate_positions(stamps, poses, query, max_gap=1.0)
    np.testing.assert_array_equal(valid, [False, True, True, True, False, True, False])
    np.testing.assert_allclose(values[valid], [[0.5, 0.0], [2.0, 2.0], [2.0, 4.0], [0.0, 0.0]])
    np.testing.assert_array_equal(truth_covers(stamps, query, 1.0), valid)
    # The gap's bound is inclusive; a series of one stamp covers only that stamp; none nothing.
    assert truth_covers(stamps, np.array([5.0]), 8.0).tolist() == [True]
    assert truth_covers(stamps, np.array([5.0]), np.nextafter(8.0, 0.0)).tolist() == [False]
    assert truth_covers(np.array([3.0]), np.array([2.9, 3.0, 3.1]), 1.0).tolist() == [
        False, True, False]
    assert truth_covers(np.zeros(0), query, 1.0).tolist() == [False] * len(query)


def test_error_stats_rmse_max_final():
    stats = error_stats(np.array([3.0, 4.0, 0.0]))
    assert stats == {"rmse": pytest.approx(math.sqrt(25.0 / 3.0)), "max": 4.0, "final": 0.0}
    assert math.isnan(error_stats(np.zeros(0))["rmse"])


def test_ospa_closed_forms():
    points = RNG.uniform(-10, 10, size=(5, 2))
    assert ospa(points, points[::-1]) == 0.0
    assert ospa(np.zeros((0, 2)), np.zeros((0, 2))) == 0.0
    assert ospa(points, np.zeros((0, 2)), cutoff=2.0) == 2.0
    # One truth point missing from the estimate: sqrt(c^p * 1 / n).
    assert ospa(points[:4], points, cutoff=2.0, order=2) == pytest.approx(2.0 / math.sqrt(5.0))
    # Every point displaced by d < c: OSPA = d.
    assert ospa(points + (0.3, 0.4), points, cutoff=2.0) == pytest.approx(0.5)
    # Displacements beyond c cost c.
    assert ospa(points + (30.0, 0.0), points, cutoff=2.0) == pytest.approx(2.0)


def test_landmarks_matched_by_id_count_duplicates_and_far_ones():
    truth = LandmarkSet(np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]]), np.array([0, 1, 2]))
    estimate = np.array([[0.1, 0.0], [10.0, 0.2], [10.5, 0.0], [25.0, 0.0], [40.0, 0.0]])
    ids = np.array([0, 1, 1, 2, -1])
    metrics = landmark_metrics(estimate, ids, truth, cutoff=2.0)
    assert metrics["match_method"] == "id"
    assert (metrics["matched"], metrics["missed"], metrics["spurious"]) == (2, 1, 3)
    assert metrics["rmse"] == pytest.approx(math.sqrt((0.01 + 0.04) / 2))


def test_landmarks_without_ids_use_optimal_assignment():
    truth = np.array([[0.0, 0.0], [1.0, 0.0]])
    # Greedy nearest-first pairs (0.6, 0) with (1, 0), leaving (1.9, 0) 1.9 m from (0, 0).
    estimate = np.array([[0.6, 0.0], [1.9, 0.0]])
    rows, cols, method = match_landmarks(estimate, np.full(2, -1), truth, np.full(2, -1), 2.0)
    assert method == "assignment"
    assert sorted(zip(rows.tolist(), cols.tolist())) == [(0, 0), (1, 1)]


def test_unknown_association_maps_are_matched_by_position_not_by_creation_labels():
    # Labels of an unknown-association map name the observation that created each landmark:
    # here a misread barcode labelled the landmark at (5, 0) with id 0.
    truth = LandmarkSet(np.array([[0.0, 0.0], [5.0, 0.0]]), np.array([0, 1]))
    landmarks = LandmarkEstimate(np.array([[0.1, 0.0], [5.0, 0.2]]), np.zeros((2, 2, 2)),
                                 np.array([0, 0]), np.ones(2))
    stamps = np.arange(3.0)
    poses = np.zeros((3, 3))

    def landmark_result(params, match="auto"):
        run = RunData(PoseSeries(stamps, poses), None, None, PoseSeries(stamps, poses),
                      landmarks, truth, {"params": params}, {})
        return evaluate_run(run, match=match).metrics["landmarks"]

    by_position = landmark_result({"association": "monte_carlo"})
    assert by_position["match_method"] == "assignment"
    assert (by_position["matched"], by_position["spurious"]) == (2, 0)
    assert by_position["rmse"] == pytest.approx(math.sqrt((0.01 + 0.04) / 2))
    by_label = landmark_result({"association": "known"})
    assert by_label["match_method"] == "id"
    assert (by_label["matched"], by_label["missed"], by_label["spurious"]) == (1, 1, 1)
    assert landmark_result({"association": "ml"}, match="id")["match_method"] == "id"
    assert landmark_result({}, match="assignment")["match_method"] == "assignment"
    # A recording without the replay's parameters (a live node) keeps its ids.
    assert landmark_result({})["match_method"] == "id"
    with pytest.raises(ValueError, match="match"):
        matches_by_id({}, "nearest")


def test_a_reference_point_off_the_base_is_compared_at_that_point():
    # The base weaves left and right; the GPS antenna sits 3 m ahead and 1 m left of it.
    stamps = np.arange(50.0)
    theta = 1.5 * np.sin(np.linspace(0.0, 2.0 * np.pi, 50))
    base = np.column_stack([np.cumsum(np.cos(theta)), np.cumsum(np.sin(theta)), theta])
    antenna = base[:, :2] + np.column_stack([3.0 * np.cos(theta) - np.sin(theta),
                                             3.0 * np.sin(theta) + np.cos(theta)])
    gps = np.column_stack([antenna, np.full(50, np.nan)])

    def aligned_rmse(offset):
        truth = PoseSeries(stamps, gps, "map", "gps_antenna", True, offset)
        run = RunData(PoseSeries(stamps, base), None, None, truth, None, None, {}, {})
        return evaluate_run(run).metrics["estimate"]["aligned"]["rmse"]

    assert aligned_rmse(np.array([3.0, 1.0])) == pytest.approx(0.0, abs=1e-9)
    assert aligned_rmse(None) > 0.5     # the base is not where the GPS is


def test_markdown_table_lists_every_trajectory():
    stamps = np.arange(5.0)
    truth = PoseSeries(stamps, np.zeros((5, 3)))
    result = evaluate_trajectory(stamps, np.ones((5, 2)), truth).metrics()
    table = markdown_table({"estimate": result, "dead_reckoning": result,
                            "association": {"checked": 10, "correct": 9, "accuracy": 0.9}})
    assert "| estimate (at the time) | 1.414 |" in table
    assert "| dead reckoning |" in table
    assert "90.00 % correct (9 of 10)" in table


def test_json_ready_replaces_nan_and_infinity():
    assert json_ready({"a": [1.0, math.nan], "b": {"c": math.inf}, "d": "x"}) == \
        {"a": [1.0, None], "b": {"c": None}, "d": "x"}


@pytest.mark.parametrize("overconfidence", [1.0, 25.0])
def test_nees_of_errors_drawn_from_the_claimed_covariance_is_chi_square(overconfidence):
    """Errors drawn from N(0, P) against P: NEES chi-square with 2 degrees of freedom (mean 2,
    median 2 ln 2, 95 % within 5.991); against P / 25 (sigmas claimed 5x too small) every figure
    grows 25x and few samples stay within."""
    count = 20000
    rng = np.random.default_rng(11)
    angles = rng.uniform(0.0, np.pi, count)
    rotations = np.stack([np.stack([np.cos(angles), -np.sin(angles)], -1),
                          np.stack([np.sin(angles), np.cos(angles)], -1)], -2)
    sigmas = rng.uniform(0.01, 2.0, (count, 2))
    covariances = rotations @ (sigmas[:, :, None] ** 2 * np.eye(2)) @ rotations.transpose(0, 2, 1)
    errors = np.einsum("nij,nj->ni", rotations, sigmas * rng.standard_normal((count, 2)))
    summary = nees_summary(errors, covariances / overconfidence)
    spread = 4.0 * 2.0 / math.sqrt(count)  # 4 standard errors of the mean of chi2(2)
    assert summary["samples"] == count
    assert summary["mean"] == pytest.approx(2.0 * overconfidence, abs=spread * overconfidence)
    assert summary["median"] == pytest.approx(2.0 * math.log(2.0) * overconfidence,
                                              rel=0.05)
    within = 1.0 - math.exp(-5.991 / (2.0 * overconfidence))
    assert summary["within_95"] == pytest.approx(within, abs=0.01)
    assert nees_summary(errors[:3], np.zeros((3, 2, 2)))["samples"] == 0


def test_evaluation_reports_the_consistency_of_the_pose_and_the_map():
    """A run whose estimate is shifted by (0.3, 0.4) (which the alignment removes: NEES 0)
    and whose landmarks are shifted by that and 0.1 m more while claiming 0.01 m (NEES 100):
    both in the metrics and the table."""
    stamps = np.arange(20.0)
    truth_poses = np.column_stack([stamps, np.sin(stamps), np.zeros(20)])
    truth = PoseSeries(stamps, truth_poses)
    estimate = PoseSeries(stamps, truth_poses + [0.3, 0.4, 0.0])
    landmarks_truth = LandmarkSet(np.array([[0.0, 5.0], [10.0, -5.0]]), np.array([0, 1]))
    estimated = LandmarkEstimate(landmarks_truth.positions + [0.4, 0.4],
                                 np.tile(np.eye(2) * 1e-4, (2, 1, 1)), np.array([0, 1]),
                                 np.ones(2))
    run = RunData(estimate, None, None, truth, estimated, landmarks_truth, {}, {},
                  estimate_covariances=np.tile(np.eye(2) * 0.25, (20, 1, 1)))
    metrics = evaluate_run(run).metrics
    assert metrics["estimate"]["nees"]["samples"] == 20
    assert metrics["estimate"]["nees"]["median"] == pytest.approx(0.0, abs=1e-9)
    assert metrics["landmarks"]["nees"]["median"] == pytest.approx(100.0, rel=1e-6)
    assert "landmarks median 100.0, 0 % within 5.99" in markdown_table(metrics)
