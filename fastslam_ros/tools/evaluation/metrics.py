# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Trajectory and map metrics shared by the evaluations of both nodes (ROS-free).

SE(2) alignment, ATE statistics with jumps, interpolation of the ground truth (never across a
gap longer than ``max_gap``), OSPA, landmark matching, and the small helpers every evaluation
needs (poses of PoseStamped messages, strict JSON).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from fastslam_ros.core.geometry import compose, quaternion_to_yaw, rigid_fit
from fastslam_ros.node_support.timing import interpolate_poses
from fastslam_ros.tools.bags.bag_schema import LandmarkSet, PoseSeries, time_msg_to_stamp

OSPA_CUTOFF = 2.0
"""OSPA cut-off c (m): a missing or spurious landmark costs as much as one c metres off."""
OSPA_ORDER = 2
"""OSPA order p."""
DEFAULT_MAX_GAP = 1.0
"""Ground truth is not interpolated across gaps longer than this (s)."""
JUMP_THRESHOLD = 0.5
"""An estimate jumps (m) when its error changes by more than this from one sample to the next:
it moved that much further than the truth did, e.g. when another particle became the best."""

CHI2_95_2DOF = 5.991
"""95 % quantile of the chi-square distribution with 2 degrees of freedom: a consistent
estimate's planar error lies within it 95 % of the time (NEES, ``nees_summary``)."""


@dataclass
class Transform2D:
    """A planar rigid transform ``p -> R(yaw) p + translation``."""

    yaw: float = 0.0
    translation: np.ndarray = field(default_factory=lambda: np.zeros(2))

    @property
    def rotation(self) -> np.ndarray:
        """The 2x2 rotation matrix."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return np.array([[c, -s], [s, c]])

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Transform (N, 2) points."""
        return np.asarray(points, dtype=float) @ self.rotation.T + self.translation


def align_se2(estimate: np.ndarray, reference: np.ndarray) -> Transform2D:
    """The rigid transform minimising ``sum |T(estimate_i) - reference_i|^2`` (closed form,
    ``core.geometry.rigid_fit``)."""
    estimate = np.asarray(estimate, dtype=float)
    reference = np.asarray(reference, dtype=float)
    if len(estimate) == 0:
        return Transform2D()
    yaw, translation = rigid_fit(estimate, reference)
    return Transform2D(float(yaw), translation)


def error_stats(errors: np.ndarray) -> dict[str, float]:
    """RMSE, maximum and final value of position errors (m); NaN when there are none."""
    if len(errors) == 0:
        return {"rmse": math.nan, "max": math.nan, "final": math.nan}
    return {"rmse": float(np.sqrt(np.mean(errors**2))), "max": float(np.max(errors)),
            "final": float(errors[-1])}


def interpolate_positions(stamps: np.ndarray, poses: np.ndarray, query: np.ndarray,
                          max_gap: float = DEFAULT_MAX_GAP) -> tuple[np.ndarray, np.ndarray]:
    """Positions (N, 2) at ``query`` stamps of a pose series (``timing.interpolate_poses``),
    and a mask of the valid ones.

    A query is valid where ``truth_covers`` says so: inside the series, not across a gap
    longer than ``max_gap`` s.
    """
    stamps = np.asarray(stamps, dtype=float)
    query = np.asarray(query, dtype=float)
    if len(stamps) == 0:
        return np.zeros((len(query), 2)), np.zeros(len(query), dtype=bool)
    return interpolate_poses(stamps, poses, query)[:, :2], truth_covers(stamps, query, max_gap)


def truth_covers(stamps: np.ndarray, query: np.ndarray, max_gap: float = DEFAULT_MAX_GAP
                 ) -> np.ndarray:
    """Mask of the ``query`` stamps a timed series (sorted ``stamps``) can be interpolated at:
    inside the series, and on one of its stamps or between two at most ``max_gap`` s apart."""
    stamps = np.asarray(stamps, dtype=float)
    query = np.asarray(query, dtype=float)
    if len(stamps) == 0:
        return np.zeros(len(query), dtype=bool)
    upper = np.clip(np.searchsorted(stamps, query, side="left"), 0, len(stamps) - 1)
    lower = np.clip(upper - 1, 0, len(stamps) - 1)
    exact = stamps[upper] == query
    inside = (query >= stamps[0]) & (query <= stamps[-1])
    return inside & (exact | (stamps[upper] - stamps[lower] <= max_gap))


@dataclass
class TrajectoryResult:
    """A trajectory matched to the ground truth, raw and aligned."""

    stamps: np.ndarray
    estimate: np.ndarray
    reference: np.ndarray
    alignment: Transform2D
    raw_errors: np.ndarray
    aligned_errors: np.ndarray

    def error_steps(self) -> np.ndarray:
        """(N - 1,) change of the position error between consecutive samples (m): how much
        further than the truth the estimate moved."""
        return np.linalg.norm(np.diff(self.estimate - self.reference, axis=0), axis=1)

    def metrics(self) -> dict[str, Any]:
        """ATE statistics (m) raw and aligned, the alignment, the number of samples and the
        jumps (error steps above ``JUMP_THRESHOLD``: how many, and the largest step)."""
        steps = self.error_steps()
        return {"raw": error_stats(self.raw_errors), "aligned": error_stats(self.aligned_errors),
                "alignment": {"yaw": self.alignment.yaw,
                              "x": float(self.alignment.translation[0]),
                              "y": float(self.alignment.translation[1])},
                "samples": int(len(self.stamps)),
                "jumps": {"threshold": JUMP_THRESHOLD,
                          "count": int(np.count_nonzero(steps > JUMP_THRESHOLD)),
                          "max_step": float(steps.max()) if len(steps) else 0.0}}


def reference_positions(poses: np.ndarray, offset: np.ndarray | None) -> np.ndarray:
    """Positions (N, 2) of the point the ground truth measures, from estimated poses (N, 3):
    the base itself, or the point at ``offset`` (x, y) in the base frame (a GPS antenna)."""
    poses = np.asarray(poses, dtype=float)
    if offset is None:
        return poses[:, :2]
    return compose(poses, np.array([offset[0], offset[1], 0.0]))[:, :2]


def evaluate_trajectory(stamps: np.ndarray, positions: np.ndarray, ground_truth: PoseSeries,
                        max_gap: float = DEFAULT_MAX_GAP) -> TrajectoryResult | None:
    """Match an estimated trajectory to the ground truth; None when no sample overlaps."""
    reference, valid = interpolate_positions(ground_truth.stamps, ground_truth.poses,
                                             stamps, max_gap)
    if not np.any(valid):
        return None
    estimate = np.asarray(positions, dtype=float)[valid]
    reference = reference[valid]
    alignment = align_se2(estimate, reference)
    return TrajectoryResult(
        stamps=np.asarray(stamps)[valid], estimate=estimate, reference=reference,
        alignment=alignment,
        raw_errors=np.linalg.norm(estimate - reference, axis=1),
        aligned_errors=np.linalg.norm(alignment.apply(estimate) - reference, axis=1))


def ospa(estimate: np.ndarray, truth: np.ndarray, cutoff: float = OSPA_CUTOFF,
         order: int = OSPA_ORDER) -> float:
    """OSPA distance (m) between two point sets (Schuhmacher et al. 2008)."""
    estimate = np.asarray(estimate, dtype=float).reshape(-1, 2)
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    larger = max(len(estimate), len(truth))
    if larger == 0:
        return 0.0
    if min(len(estimate), len(truth)) == 0:
        return float(cutoff)
    distance = np.minimum(np.linalg.norm(estimate[:, None] - truth[None], axis=2), cutoff)
    cost = distance**order
    rows, cols = linear_sum_assignment(cost)
    total = cost[rows, cols].sum() + cutoff**order * (larger - len(rows))
    return float((total / larger) ** (1.0 / order))


def match_landmarks(estimate: np.ndarray, estimate_ids: np.ndarray, truth: np.ndarray,
                    truth_ids: np.ndarray, cutoff: float,
                    by_id: bool = True) -> tuple[np.ndarray, np.ndarray, str]:
    """Pairs ``(estimate index, truth index)`` closer than ``cutoff`` and the method used.

    By id when ``by_id`` and both sides carry ids (the nearest estimate of each truth id;
    estimates without an id are then unmatched); otherwise by optimal assignment of the
    distances.
    """
    estimate = np.asarray(estimate, dtype=float).reshape(-1, 2)
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    empty = np.zeros(0, dtype=int)
    if len(estimate) == 0 or len(truth) == 0:
        return empty, empty, "none"
    distance = np.linalg.norm(estimate[:, None] - truth[None], axis=2)
    if by_id and np.any(np.asarray(estimate_ids) >= 0) and np.any(np.asarray(truth_ids) >= 0):
        method = "id"
        pairs = []
        for truth_index, truth_id in enumerate(truth_ids):
            candidates = np.flatnonzero(estimate_ids == truth_id) if truth_id >= 0 else empty
            if len(candidates):
                best = candidates[np.argmin(distance[candidates, truth_index])]
                pairs.append((best, truth_index))
        rows = np.array([p[0] for p in pairs], dtype=int)
        cols = np.array([p[1] for p in pairs], dtype=int)
    else:
        method = "assignment"
        rows, cols = linear_sum_assignment(np.minimum(distance, cutoff * 10.0))
    close = distance[rows, cols] <= cutoff
    return rows[close], cols[close], method


def landmark_metrics(estimate: np.ndarray, estimate_ids: np.ndarray, truth: LandmarkSet,
                     cutoff: float = OSPA_CUTOFF, by_id: bool = True,
                     covariances: np.ndarray | None = None) -> dict[str, Any]:
    """RMSE of matched landmarks, missed / spurious counts and OSPA (positions in map frame);
    with the landmarks' ``covariances`` (N, 2, 2, same frame) also their ``nees``."""
    rows, cols, method = match_landmarks(estimate, estimate_ids, truth.positions, truth.ids,
                                         cutoff, by_id)
    offsets = np.asarray(estimate).reshape(-1, 2)[rows] - truth.positions[cols]
    errors = np.linalg.norm(offsets, axis=1)
    consistency = {} if covariances is None else {
        "nees": nees_summary(offsets, np.asarray(covariances)[rows])}
    return {**consistency, "rmse": float(np.sqrt(np.mean(errors**2))) if len(errors) else math.nan,
            "matched": int(len(rows)), "missed": int(len(truth.positions) - len(rows)),
            "spurious": int(len(estimate) - len(rows)), "estimated": int(len(estimate)),
            "truth": int(len(truth.positions)), "match_method": method, "cutoff": cutoff,
            "ospa": ospa(estimate, truth.positions, OSPA_CUTOFF, OSPA_ORDER)}


def nees_summary(errors: np.ndarray, covariances: np.ndarray) -> dict[str, Any]:
    """Consistency of planar errors (N, 2) against the covariances (N, 2, 2) the estimator
    claimed: the normalized estimation error squared e^T P^-1 e (NEES), which averages 2 for a
    consistent estimator (chi-square, 2 degrees of freedom; median 1.39): its ``mean`` and
    ``median``, the share ``within_95``
    of samples below ``CHI2_95_2DOF`` (0.95 expected) and ``samples`` (those with a positive
    definite covariance)."""
    errors = np.asarray(errors, dtype=float).reshape(-1, 2)
    cov = np.asarray(covariances, dtype=float).reshape(-1, 2, 2)
    det = cov[:, 0, 0] * cov[:, 1, 1] - cov[:, 0, 1] * cov[:, 1, 0]
    usable = (det > 0.0) & (cov[:, 0, 0] > 0.0)
    e, c, det = errors[usable], cov[usable], det[usable]
    values = (e[:, 0] ** 2 * c[:, 1, 1] - e[:, 0] * e[:, 1] * (c[:, 0, 1] + c[:, 1, 0])
              + e[:, 1] ** 2 * c[:, 0, 0]) / det
    if not len(values):
        return {"mean": math.nan, "median": math.nan, "within_95": math.nan, "samples": 0}
    return {"mean": float(values.mean()), "median": float(np.median(values)),
            "within_95": float(np.mean(values <= CHI2_95_2DOF)), "samples": int(len(values))}


def planar_covariances(messages: list[Any]) -> np.ndarray | None:
    """(N, 2, 2) position covariances of PoseWithCovarianceStamped messages (None for
    PoseStamped ones, which claim none)."""
    if not messages or not hasattr(messages[0].pose, "covariance"):
        return None
    rows = np.array([np.asarray(msg.pose.covariance, dtype=float)[[0, 1, 6, 7]]
                     for msg in messages])
    return rows.reshape(-1, 2, 2)


def pose_stamped_series(messages: list[Any]) -> PoseSeries:
    """Planar poses of PoseStamped / PoseWithCovarianceStamped messages."""
    stamps, poses = [], []
    for msg in messages:
        pose = msg.pose.pose if hasattr(msg.pose, "pose") else msg.pose
        q = pose.orientation
        stamps.append(time_msg_to_stamp(msg.header.stamp))
        poses.append((pose.position.x, pose.position.y,
                      quaternion_to_yaw(q.x, q.y, q.z, q.w)))
    frame = messages[0].header.frame_id if messages else "map"
    return PoseSeries(np.array(stamps), np.array(poses).reshape(-1, 3), frame, "base_link")


def json_ready(value: Any) -> Any:
    """``value`` with NaN and infinities replaced by None (strict JSON has no NaN)."""
    if isinstance(value, dict):
        return {key: json_ready(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(item) for item in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
