# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Score a people-tracking run: robot ATE, CLEAR MOT (MOTA, MOTP, identity switches) and OSPA.

``fastslam-eval OUT`` dispatches here when OUT (recorded by ``fastslam-replay --node
people_tracker``) holds ``/people_tracker/people``. The robot's ``~/pose`` is compared with
``/ground_truth/pose`` by the SLAM evaluation's matching and SE(2) alignment (raw and aligned
ATE; the map is known, so the raw figure is the one a user sees). The robot has converged at
the first stamp after which its raw error stays below ``CONVERGED_ERROR``.

People are scored per scan, from convergence on, inside the region the robot could see: within
the laser's range of the true robot pose with a clear line of sight on the map (a person
behind a wall cannot be tracked, an estimate there is not scored; a person hidden behind
another person is scored, as the tracker should keep them; a second set of figures leaves the
people hidden behind people out, with the tracks near them). Estimates count when their
existence is at least ``--min-existence``. CLEAR MOT (Bernardin and Stiefelhagen 2008) with a
match radius of 0.5 m: a match of the last frame is kept while within the radius, the rest
are paired by optimal assignment; an identity switch is a truth person matched to another
track than before; switches per person per minute divide by the minutes people were in
view (truth count x frame period); each switch's gap is the time between the person's two
matches (a switch after a gap below ``SHORT_GAP``: one a tracker should bridge). MOTA = 1 -
(misses + false positives + switches) / truth count; MOTP is the mean distance of the
matches. OSPA per frame with c = 1 m and order p = 2, averaged.
"""
from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from fastslam_ros.people.detection import Scan
from fastslam_ros.people.grid import OccupancyMap
from fastslam_ros.tools import cli
from fastslam_ros.output import (all_or_nothing, check_output, staged_output, write_params_yaml,
                                 write_text)
from fastslam_ros.tools.bags.bag_schema import (GROUND_TRUTH_POSE_TOPIC, MAP_TOPIC,
                                           PEOPLE_TRUTH_TOPIC, REPLAY_INFO_TOPIC, SCAN_TOPIC,
                                           PoseSeries, cloud_to_arrays,
                                           pose_series_from_messages, read_topics,
                                           time_msg_to_stamp)
from fastslam_ros.tools.evaluation.metrics import (evaluate_trajectory, json_ready, ospa,
                                        pose_stamped_series)

PEOPLE_TOPIC = "/people_tracker/people"
POSE_TOPIC = "/people_tracker/pose"
MATCH_RADIUS = 0.5
"""CLEAR MOT match radius (m)."""
BENCHMARK_RADIUS = 0.75
"""Match radius (m) of the benchmark count (Leigh et al.'s leg tracking benchmark, ICRA 2015):
every scan a frame, from the first, every published track counted."""
OSPA_CUTOFF = 1.0
OSPA_ORDER = 2
CONVERGED_ERROR = 0.5
"""The robot has converged once its raw position error stays below this (m)."""
FRAME_TOLERANCE = 0.02
"""An estimate cloud belongs to the truth frame within this many seconds."""
PERSON_RADIUS = 0.2
SHORT_GAP = 2.0
"""An identity switch after a person was unmatched (out of view, hidden or missed) for less
than this (s) counts as a short-gap switch: an occlusion a tracker should bridge."""


@dataclass
class Frame:
    """People at one stamp: ids (K,) and positions (K, 2) (estimates also existence (K,))."""

    stamp: float
    ids: np.ndarray
    positions: np.ndarray
    existence: np.ndarray | None = None


def people_frames(stamps: np.ndarray, messages: list[Any]) -> list[Frame]:
    """Frames of people clouds (x, y, id[, existence]), stamped by their headers."""
    frames = []
    for msg in messages:
        fields = cloud_to_arrays(msg)
        count = len(fields.get("x", []))
        positions = (np.stack([fields["x"], fields["y"]], axis=1).astype(float) if count
                     else np.zeros((0, 2)))
        ids = fields["id"].astype(int) if "id" in fields else np.arange(count)
        existence = fields["existence"].astype(float) if "existence" in fields else None
        frames.append(Frame(time_msg_to_stamp(msg.header.stamp), ids, positions, existence))
    return frames


@dataclass(frozen=True)
class LaserView:
    """What the laser (at the robot's centre, as the simulator puts it) sees: its range, and a
    partial scan's span (a ``Scan`` with the run's beam angles; None: a full turn)."""

    max_range: float
    span: Scan | None = None


def visible(grid: OccupancyMap, pose: np.ndarray, points: np.ndarray, view: LaserView
            ) -> np.ndarray:
    """Whether each point (K, 2) is within the laser's range and span from ``pose`` with a
    clear line of sight on the map (people do not block it)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    offset = points - pose[:2]
    distance = np.hypot(offset[:, 0], offset[:, 1])
    heading = np.arctan2(offset[:, 1], offset[:, 0])
    wall = grid.cast(np.broadcast_to(pose[:2], points.shape), heading, view.max_range)
    seen = (distance <= view.max_range) & (wall >= distance - PERSON_RADIUS)
    if view.span is not None:
        seen &= view.span.covers(heading - pose[2])
    return seen


def hidden_by_people(pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Whether each person (K, 2) is hidden from ``pose`` behind another of them (its centre
    ray passes within PERSON_RADIUS of a nearer one)."""
    offset = np.asarray(points, dtype=float).reshape(-1, 2) - pose[:2]
    distance = np.hypot(offset[:, 0], offset[:, 1])
    direction = offset / np.maximum(distance, 1e-9)[:, None]
    along = direction @ offset.T                                    # (K, K): j along ray i
    across = np.sqrt(np.maximum(distance[None, :] ** 2 - along ** 2, 0.0))
    blocks = (across < PERSON_RADIUS) & (along > 0.0) & (distance[None, :] < distance[:, None])
    np.fill_diagonal(blocks, False)
    return blocks.any(axis=1)


def benchmark_counted(grid: OccupancyMap, pose: np.ndarray, points: np.ndarray,
                      view: LaserView) -> np.ndarray:
    """Whether the leg tracking benchmark's count scores each person (K, 2) seen from
    ``pose``: in range, span and line of sight, and not hidden behind another person."""
    counted = visible(grid, pose, points, view)
    counted[counted] &= ~hidden_by_people(pose, points[counted])
    return counted


def pose_at(series: PoseSeries, stamp: float) -> np.ndarray:
    """The pose of ``series`` at its first stamp not before ``stamp`` (its last after it)."""
    return series.poses[min(np.searchsorted(series.stamps, stamp), len(series.stamps) - 1)]


def without_hidden(gt: Frame, est: Frame, hidden: np.ndarray,
                   radius: float = MATCH_RADIUS) -> tuple[Frame, Frame]:
    """Frames with the truth people ``hidden`` (not scored) left out, and with them every
    estimate within the match radius of one of them and nearer to it than to any other truth
    person (a track kept through an occlusion, or of a person whose centre is just out of
    view while a leg is in it, is then neither a hit nor a false positive)."""
    if not hidden.any():
        return gt, est
    keep_est = np.ones(len(est.ids), dtype=bool)
    if len(est.ids):
        distance = np.linalg.norm(est.positions[:, None] - gt.positions[None], axis=2)
        nearest = np.argmin(distance, axis=1)
        keep_est = ~(hidden[nearest] & (distance[np.arange(len(est.ids)), nearest] <= radius))
    shown = ~hidden
    return (Frame(gt.stamp, gt.ids[shown], gt.positions[shown]),
            Frame(est.stamp, est.ids[keep_est], est.positions[keep_est]))


def published(frame: Frame, min_existence: float) -> np.ndarray:
    """Which tracks of ``frame`` count as published: existence at least ``min_existence``
    (every one when the output carries no existence)."""
    if frame.existence is None:
        return np.ones(len(frame.ids), dtype=bool)
    return frame.existence >= min_existence


def in_view(grid: OccupancyMap, pose: np.ndarray, truth: Frame, estimate: Frame,
            view: LaserView, min_existence: float, radius: float = MATCH_RADIUS
            ) -> tuple[Frame, Frame]:
    """The truth people in view from ``pose`` and the published tracks (existence at least
    ``min_existence``) to score. The view is judged at a person's centre, and a track within
    ``radius`` of a truth person is judged by its nearest one: scored when that person is in
    view (even where the track's own line of sight grazes a door jamb or leaves the span), left
    out when not (one leg in the span, the centre out of it). A track near no one is scored
    where it is in view."""
    seen = visible(grid, pose, truth.positions, view)
    keep_est = visible(grid, pose, estimate.positions, view)
    if len(estimate.ids) and len(truth.ids):
        distance = np.linalg.norm(estimate.positions[:, None] - truth.positions[None], axis=2)
        nearest = np.argmin(distance, axis=1)
        near = distance[np.arange(len(estimate.ids)), nearest] <= radius
        keep_est = np.where(near, seen[nearest], keep_est)
    keep_est &= published(estimate, min_existence)
    return (Frame(truth.stamp, truth.ids[seen], truth.positions[seen]),
            Frame(estimate.stamp, estimate.ids[keep_est], estimate.positions[keep_est]))


def clear_mot(truth: list[Frame], estimates: list[Frame], radius: float = MATCH_RADIUS
              ) -> dict[str, Any]:
    """CLEAR MOT over paired frames (same length): MOTA, MOTP, misses, false positives,
    identity switches (with the gap before each: the time between the person's two matches,
    and how many came after less than SHORT_GAP), truth count, matches."""
    last_match: dict[int, int] = {}   # truth id -> track id of its latest match
    last_stamp: dict[int, float] = {}  # truth id -> stamp of its latest match
    gaps: list[float] = []
    previous: dict[int, int] = {}     # truth id -> track id matched in the previous frame
    misses = false_positives = switches = total = matches = 0
    distance_sum = 0.0
    for gt, est in zip(truth, estimates):
        total += len(gt.ids)
        distance = np.linalg.norm(gt.positions[:, None] - est.positions[None], axis=2) \
            if len(gt.ids) and len(est.ids) else np.zeros((len(gt.ids), len(est.ids)))
        gt_index = {int(i): k for k, i in enumerate(gt.ids)}
        est_index = {int(i): k for k, i in enumerate(est.ids)}
        pairs = []
        for truth_id, track_id in previous.items():
            g, e = gt_index.get(truth_id), est_index.get(track_id)
            if g is not None and e is not None and distance[g, e] <= radius:
                pairs.append((g, e))
        used_g = {g for g, _ in pairs}
        used_e = {e for _, e in pairs}
        free_g = [g for g in range(len(gt.ids)) if g not in used_g]
        free_e = [e for e in range(len(est.ids)) if e not in used_e]
        if free_g and free_e:
            cost = distance[np.ix_(free_g, free_e)]
            rows, cols = linear_sum_assignment(np.where(cost <= radius, cost, 1e6))
            for r, c in zip(rows, cols):
                if cost[r, c] <= radius:
                    pairs.append((free_g[r], free_e[c]))
        current = {}
        for g, e in pairs:
            truth_id, track_id = int(gt.ids[g]), int(est.ids[e])
            if truth_id in last_match and last_match[truth_id] != track_id:
                switches += 1
                gaps.append(float(gt.stamp - last_stamp[truth_id]))
            last_match[truth_id] = track_id
            last_stamp[truth_id] = float(gt.stamp)
            current[truth_id] = track_id
            distance_sum += float(distance[g, e])
        previous = current
        matches += len(pairs)
        misses += len(gt.ids) - len(pairs)
        false_positives += len(est.ids) - len(pairs)
    return {"mota": 1.0 - (misses + false_positives + switches) / total if total else math.nan,
            "motp": distance_sum / matches if matches else math.nan,
            "misses": misses, "false_positives": false_positives, "id_switches": switches,
            "id_switch_gaps": gaps,
            "id_switches_short_gap": sum(gap < SHORT_GAP for gap in gaps),
            "truth_count": total, "matches": matches}


def benchmark_mot(ground_truth: PoseSeries, grid: OccupancyMap, truth_frames: list[Frame],
                  estimate_frames: list[Frame], view: LaserView, min_existence: float
                  ) -> dict[str, Any]:
    """CLEAR MOT as the leg tracking benchmark counts: BENCHMARK_RADIUS, every scan a frame
    (from the first, converged or not; a scan without output has no tracks), the people the
    laser sees (in range, in line of sight, not hidden behind another person: the annotated
    ones), and every published track, wherever it is (false positives included)."""
    by_stamp = {round(f.stamp / FRAME_TOLERANCE): f for f in estimate_frames}
    truths, estimates = [], []
    for frame in truth_frames:
        est = by_stamp.get(round(frame.stamp / FRAME_TOLERANCE))
        if est is None:
            est = Frame(frame.stamp, np.zeros(0, np.int32), np.zeros((0, 2)))
        else:
            keep = published(est, min_existence)
            est = Frame(est.stamp, est.ids[keep], est.positions[keep])
        seen = benchmark_counted(grid, pose_at(ground_truth, frame.stamp), frame.positions, view)
        truths.append(Frame(frame.stamp, frame.ids[seen], frame.positions[seen]))
        estimates.append(est)
    mot = clear_mot(truths, estimates, BENCHMARK_RADIUS)
    mot["frames"] = len(truths)
    return mot


def convergence_time(result) -> float:
    """First stamp after which the raw position error stays below CONVERGED_ERROR (inf:
    never)."""
    bad = np.flatnonzero(result.raw_errors >= CONVERGED_ERROR)
    if len(bad) == 0:
        return float(result.stamps[0])
    if bad[-1] == len(result.stamps) - 1:
        return math.inf
    return float(result.stamps[bad[-1] + 1])


def evaluate_people(estimate: PoseSeries, ground_truth: PoseSeries, grid: OccupancyMap,
                    truth_frames: list[Frame], estimate_frames: list[Frame], view: LaserView,
                    min_existence: float = 0.5) -> tuple[dict[str, Any], Any]:
    """Every metric of a run (JSON-ready dict) and the robot's trajectory match."""
    trajectory = evaluate_trajectory(estimate.stamps, estimate.poses[:, :2], ground_truth)
    metrics: dict[str, Any] = {"robot": trajectory.metrics() if trajectory else None}
    converged = convergence_time(trajectory) if trajectory else math.inf
    start = float(ground_truth.stamps[0])
    metrics["convergence_time"] = converged - start
    after = trajectory.stamps >= converged if trajectory else np.zeros(0, bool)
    if trajectory is not None and after.any():
        metrics["robot_after_convergence_raw_rmse"] = float(
            np.sqrt(np.mean(trajectory.raw_errors[after] ** 2)))
    by_stamp = {round(f.stamp / FRAME_TOLERANCE): f for f in estimate_frames}
    truths, estimates, ospas = [], [], []
    shown_truths, shown_estimates = [], []
    for frame in truth_frames:
        if frame.stamp < converged:
            continue
        est = by_stamp.get(round(frame.stamp / FRAME_TOLERANCE))
        if est is None:
            continue
        pose = pose_at(ground_truth, frame.stamp)
        gt, kept = in_view(grid, pose, frame, est, view, min_existence)
        truths.append(gt)
        estimates.append(kept)
        ospas.append(ospa(kept.positions, gt.positions, OSPA_CUTOFF, OSPA_ORDER))
        shown_gt, shown_est = without_hidden(gt, kept, hidden_by_people(pose, gt.positions))
        shown_truths.append(shown_gt)
        shown_estimates.append(shown_est)
    metrics["people_unhidden"] = clear_mot(shown_truths, shown_estimates)
    metrics["benchmark"] = benchmark_mot(ground_truth, grid, truth_frames, estimate_frames,
                                         view, min_existence)
    mot = clear_mot(truths, estimates)
    period = float(np.median(np.diff([f.stamp for f in truths]))) if len(truths) > 1 else 0.0
    person_minutes = mot["truth_count"] * period / 60.0
    mot["frames"] = len(truths)
    mot["people_seen"] = len({int(i) for f in truths for i in f.ids})
    mot["person_minutes"] = person_minutes
    mot["id_switches_per_person_minute"] = (mot["id_switches"] / person_minutes
                                            if person_minutes else math.nan)
    metrics["people"] = mot
    metrics["ospa"] = {"mean": float(np.mean(ospas)) if ospas else math.nan,
                       "cutoff": OSPA_CUTOFF, "order": OSPA_ORDER}
    return metrics, trajectory


# ---------------------------------------------------------------- a recorded run


def grid_from_message(msg: Any) -> OccupancyMap:
    """An OccupancyMap of a (rosbags or rclpy) nav_msgs/OccupancyGrid."""
    info = msg.info
    values = np.asarray(msg.data, dtype=np.int16).reshape(info.height, info.width)
    return OccupancyMap.from_occupancy(values, info.resolution,
                                       (info.origin.position.x, info.origin.position.y))


def is_people_run(topics: dict[str, str] | set[str]) -> bool:
    """Whether a bag holds a people-tracking run (or its input)."""
    return PEOPLE_TOPIC in topics or PEOPLE_TRUTH_TOPIC in topics


@dataclass
class RecordedPeopleRun:
    """A people run as the evaluator reads it: the estimate and the truth, the map, the
    people per scan, what the laser could see, and the replay's info (empty without it)."""

    estimate: PoseSeries
    truth: PoseSeries
    grid: OccupancyMap
    truth_frames: list[Frame]
    estimate_frames: list[Frame]
    view: LaserView
    info: dict[str, Any]


def read_people_run(out_path: str | Path, ground_truth_path: str | Path | None = None
                    ) -> RecordedPeopleRun:
    """Read a recorded run (and its ground truth, from ``out_path`` or its own bag)."""
    topics = [POSE_TOPIC, PEOPLE_TOPIC, REPLAY_INFO_TOPIC]
    truth_topics = [GROUND_TRUTH_POSE_TOPIC, PEOPLE_TRUTH_TOPIC, MAP_TOPIC, SCAN_TOPIC]
    if ground_truth_path is None:
        data = read_topics(out_path, topics + truth_topics)
    else:
        data = read_topics(out_path, topics)
        data.update(read_topics(ground_truth_path, truth_topics))
    missing = [t for t in (POSE_TOPIC, PEOPLE_TOPIC, GROUND_TRUTH_POSE_TOPIC, PEOPLE_TRUTH_TOPIC,
                           MAP_TOPIC) if not data[t][1]]
    if missing:
        raise ValueError(f"no message on {', '.join(missing)}")
    scans = data[SCAN_TOPIC][1]
    max_range = float(scans[0].range_max) if scans else 12.0
    info = json.loads(data[REPLAY_INFO_TOPIC][1][-1].data) if data[REPLAY_INFO_TOPIC][1] else {}
    max_range = min(max_range, float(info.get("params", {}).get("max_range", max_range)))
    span = None
    if scans:
        first = scans[0]
        span = Scan(np.zeros(len(first.ranges)), float(first.angle_min),
                    float(first.angle_increment))
    return RecordedPeopleRun(
        pose_stamped_series(data[POSE_TOPIC][1]),
        pose_series_from_messages(data[GROUND_TRUTH_POSE_TOPIC][1]),
        grid_from_message(data[MAP_TOPIC][1][-1]), people_frames(*data[PEOPLE_TRUTH_TOPIC]),
        people_frames(*data[PEOPLE_TOPIC]), LaserView(max_range, span), info)


def evaluate_people_bag(out_path: str | Path, ground_truth_path: str | Path | None = None,
                        min_existence: float = 0.5) -> tuple[dict[str, Any], dict[str, Any]]:
    """Metrics of a recorded run and the data for a plot."""
    run = read_people_run(out_path, ground_truth_path)
    metrics, _ = evaluate_people(run.estimate, run.truth, run.grid, run.truth_frames,
                                 run.estimate_frames, run.view, min_existence)
    info = run.info
    if info:
        metrics["runtime"] = {key: info[key] for key in
                              ("wall_time", "cpu_time", "bag_duration", "real_time_factor")
                              if key in info}
        metrics["cpu_per_scan_ms"] = (1000.0 * info["cpu_time"] / max(len(run.estimate_frames), 1)
                                      if "cpu_time" in info else math.nan)
        metrics["stats"] = info.get("stats", {})
        metrics["params"] = info.get("params", {})
    plot_data = {"grid": run.grid, "estimate": run.estimate, "truth": run.truth,
                 "truth_frames": run.truth_frames, "estimate_frames": run.estimate_frames,
                 "min_existence": min_existence}
    return metrics, plot_data


def markdown_table(metrics: dict[str, Any]) -> str:
    """The summary as Markdown."""
    robot = metrics.get("robot") or {}
    people, ospa_value = metrics["people"], metrics["ospa"]

    def number(value, digits=3):
        return "-" if value is None or (isinstance(value, float) and not math.isfinite(value)) \
            else f"{value:.{digits}f}"
    lines = ["| metric | value |", "|---|---|",
             f"| robot ATE raw RMSE (m) | {number(robot.get('raw', {}).get('rmse'))} |",
             f"| robot ATE aligned RMSE (m) | {number(robot.get('aligned', {}).get('rmse'))} |",
             f"| convergence time (s) | {number(metrics['convergence_time'], 1)} |",
             f"| MOTA | {number(people['mota'])} |",
             f"| MOTP (m) | {number(people['motp'])} |",
             f"| identity switches | {people['id_switches']} "
             f"({number(people['id_switches_per_person_minute'])} per person per minute) |",
             f"| identity switches after less than {SHORT_GAP:g} s unmatched | "
             f"{people['id_switches_short_gap']} |",
             f"| misses / false positives / truth | {people['misses']} / "
             f"{people['false_positives']} / {people['truth_count']} |",
             f"| MOTA, MOTP (m), switches, people hidden behind people not scored | "
             f"{number(metrics['people_unhidden']['mota'])}, "
             f"{number(metrics['people_unhidden']['motp'])}, "
             f"{metrics['people_unhidden']['id_switches']} |",
             f"| OSPA mean (m, c = {OSPA_CUTOFF:g} m, p = {OSPA_ORDER}) | "
             f"{number(ospa_value['mean'])} |"]
    bench = metrics.get("benchmark")
    if bench:
        lines.append(f"| benchmark count ({BENCHMARK_RADIUS:g} m, every scan): MOTA, MOTP (m), "
                     f"switches | {number(bench['mota'])}, {number(bench['motp'])}, "
                     f"{bench['id_switches']} |")
    if "cpu_per_scan_ms" in metrics:
        lines.append(f"| CPU per scan (ms) | {number(metrics['cpu_per_scan_ms'], 1)} |")
    return "\n".join(lines)


def plot_people(plot_data: dict[str, Any], path: str | Path, title: str = "") -> None:
    """Map, true and estimated robot path, true people (grey) and tracks (coloured by id)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    grid = plot_data["grid"]
    figure, axes = plt.subplots(figsize=(8, 8))
    axes.imshow(np.where(grid.occupied, 0.0, np.where(grid.free, 1.0, 0.7)), cmap="gray",
                origin="lower", extent=grid.extent, vmin=0.0, vmax=1.0)
    tracks: dict[int, list[np.ndarray]] = {}
    for frame in plot_data["truth_frames"]:
        for ident, position in zip(frame.ids, frame.positions):
            tracks.setdefault(-1 - int(ident), []).append(position)
    for frame in plot_data["estimate_frames"]:
        keep = (frame.existence >= plot_data["min_existence"]) if frame.existence is not None \
            else np.ones(len(frame.ids), bool)
        for ident, position in zip(frame.ids[keep], frame.positions[keep]):
            tracks.setdefault(int(ident), []).append(position)
    palette = [plt.get_cmap("tab20")(i) for i in range(20) if i not in (14, 15)]  # no greys
    for ident, points in tracks.items():
        points = np.array(points)
        if ident < 0:
            axes.plot(points[:, 0], points[:, 1], ".", color="0.6", markersize=1)
        else:
            axes.plot(points[:, 0], points[:, 1], ".", color=palette[ident % len(palette)],
                      markersize=2)
    truth, estimate = plot_data["truth"], plot_data["estimate"]
    axes.plot(truth.poses[:, 0], truth.poses[:, 1], "k-", linewidth=1, label="robot, truth")
    axes.plot(estimate.poses[:, 0], estimate.poses[:, 1], "r--", linewidth=1,
              label="robot, estimate")
    axes.set_aspect("equal")
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.legend(loc="upper right")
    axes.set_title(title or "people tracks (colour: estimated id; grey: truth)")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def run_people_demo(out_dir: Path, seed: int = 1, duration: float = 60.0,
                    progress: bool = False, overwrite: bool = False) -> dict[str, Any]:
    """``fastslam-demo --scenario people``: simulate, replay through the node, score, plot into
    ``out_dir`` (sim_people/, sim_people.yaml, replay/, metrics.json, summary.md,
    result.png). Every output is checked before anything is written; an existing one is
    replaced only with ``overwrite`` (``fastslam_ros.output``)."""
    out_dir = Path(out_dir)
    bag_path, replay_path = out_dir / "sim_people", out_dir / "replay"
    files = {name: out_dir / name for name in ("sim_people.yaml", "summary.md", "metrics.json",
                                               "result.png")}
    for path, kind in [(bag_path, "bag"), (replay_path, "bag")] + [(f, "file")
                                                                   for f in files.values()]:
        if out_dir.is_dir():
            check_output(path, overwrite, kind)
    with all_or_nothing([out_dir, bag_path, replay_path] + list(files.values())):
        out_dir.mkdir(exist_ok=True)
        return _people_demo_outputs(out_dir, files, seed, duration, progress, overwrite)


def _people_demo_outputs(out_dir: Path, files: dict[str, Path], seed: int, duration: float,
                         progress: bool, overwrite: bool) -> dict:
    """``run_people_demo``'s work once its outputs are checked."""
    from fastslam_ros.tools.simulation.people_sim import (PeopleSimConfig, recommended_params,
                                               simulate_people, write_people_bag)
    from fastslam_ros.tools.bags.replay import replay_people_bag, summary_lines
    bag_path, replay_path = out_dir / "sim_people", out_dir / "replay"
    config = PeopleSimConfig(seed=seed, duration=duration).validate()
    write_people_bag(bag_path, simulate_people(config), config, overwrite=overwrite)
    params_path = write_params_yaml(files["sim_people.yaml"], recommended_params(config),
                                    f"people_tracker parameters of fastslam-demo (seed {seed}).",
                                    overwrite=overwrite)
    result = replay_people_bag(bag_path, params_file=params_path, out_path=replay_path,
                               progress=progress, overwrite=overwrite)
    print("\n".join(summary_lines(result)), file=sys.stderr)
    metrics, plot_data = evaluate_people_bag(replay_path)
    table = markdown_table(metrics)
    write_text(files["summary.md"], table + "\n", overwrite)
    write_text(files["metrics.json"], json.dumps(json_ready(metrics), indent=2) + "\n",
               overwrite)
    with staged_output(files["result.png"], overwrite, "file") as staged:
        plot_people(plot_data, staged, title=f"people tracking, seed {seed}, {duration:g} s")
    print(table)
    print(f"\nfiles in {out_dir}: summary.md, metrics.json, result.png, replay/, sim_people/, "
          "sim_people.yaml")
    return metrics


def main(argv: list[str] | None = None) -> int:
    """``fastslam-eval OUT`` for a people-tracking run."""
    prog = "fastslam-eval"
    parser = cli.parser(prog, __doc__, first_paragraph=True)
    parser.add_argument("out", type=Path, help="bag recorded by fastslam-replay --node "
                                               "people_tracker")
    parser.add_argument("--ground-truth", type=Path, default=None,
                        help="bag holding /ground_truth/*, /map and /scan (default: OUT)")
    parser.add_argument("--json", type=Path, default=None, help="write the metrics here")
    parser.add_argument("--plot", type=Path, default=None, help="write a figure here")
    parser.add_argument("--min-existence", type=float, default=0.5,
                        help="score estimated people at least this likely to exist")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace existing --json / --plot files (never a folder or an input)")
    args, unknown = parser.parse_known_args(argv)
    if unknown:
        return cli.fail(prog, f"not an option for a people-tracking run: {' '.join(unknown)}",
                        cli.EXIT_USAGE)
    from fastslam_ros.tools.evaluation.plot import plot_formats
    inputs = [args.out] + ([args.ground_truth] if args.ground_truth else [])
    try:
        cli.check_scoring_paths(args.out, args.ground_truth, args.json, args.plot,
                                plot_formats() if args.plot is not None else (),
                                [path for path in (args.json, args.plot) if path is not None],
                                args.overwrite)
    except (cli.UsageError, FileExistsError) as error:
        return cli.fail(prog, error)
    try:
        metrics, plot_data = evaluate_people_bag(args.out, args.ground_truth, args.min_existence)
    except cli.BAG_ERRORS as error:
        return cli.fail(prog, f"cannot score {args.out}: {error}", cli.EXIT_FAILURE)
    print(markdown_table(metrics))
    try:
        if args.json:
            write_text(args.json, json.dumps(json_ready(metrics), indent=2) + "\n",
                       args.overwrite, inputs)
        if args.plot:
            with staged_output(args.plot, args.overwrite, "file", inputs) as staged:
                plot_people(plot_data, staged)
    except OSError as error:
        return cli.fail(prog, f"cannot write: {error}", cli.EXIT_USAGE)
    return 0


if __name__ == "__main__":
    sys.exit(main())
