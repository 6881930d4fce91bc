# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Accuracy of a recorded run against ground truth: trajectory ATE, landmark RMSE and OSPA.

``fastslam-eval OUT`` reads a bag recorded by ``fastslam-replay`` (or by ``ros2 bag record`` on
a live node) and compares

* the at-the-time estimate ``/fastslam/pose``,
* the best particle's final path (the last ``/fastslam/path``),
* dead reckoning (``/odom``),

with ``/ground_truth/pose``, and the final map ``/fastslam/map_cloud`` with
``/ground_truth/landmarks`` (only the landmarks whose label appears in the input clouds, when
they carry labels: a landmark never seen cannot be missed). Each trajectory is matched to the
ground truth by linear interpolation of the ground truth at the trajectory's stamps (never
across a gap longer than ``max_gap``), and scored raw and after its own least-squares SE(2)
alignment (rotation and translation, no scale). Only positions are compared, so a position-only
reference (GPS) works.

The landmark map is put in the ground-truth frame with the final path's alignment (the map
belongs to that particle), then matched to the truth: by id when the filter associated by id
(``association: known``) and both carry ids, otherwise by optimal assignment of the distances; a
pair farther apart than ``cutoff`` counts as one missed and one spurious landmark. With unknown
association a landmark's label is only that of the observation that created it (a misread
barcode or a merged pair of close landmarks gives it a label that names another place), so the
map is judged by where its landmarks are, not by their labels. OSPA uses cut-off c = 2 m and
order p = 2:
``OSPA = ((min_assignment sum min(d, c)^p + c^p |n - m|) / max(n, m))^(1/p)``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from fastslam_ros.node_parameters import max_speed_parameter, max_yaw_rate_parameter
from fastslam_ros.node_support.timing import (MAX_ODOMETRY_COORDINATE, OdometryGate,
                                              StampGate, interpolate_poses)
from fastslam_ros.tools import cli
from fastslam_ros.tools.bags.bag_schema import (GROUND_TRUTH_LANDMARKS_TOPIC,
                                                GROUND_TRUTH_POSE_TOPIC, LANDMARKS_TOPIC,
                                                ODOM_TOPIC, REPLAY_INFO_TOPIC, TF_STATIC_TOPIC,
                                                LandmarkSet, PoseSeries, bag_topics,
                                                cloud_to_arrays, landmark_cloud_arrays,
                                                odometry_to_pose, pose_series_from_messages,
                                                read_last, read_topics, time_msg_to_stamp)
from fastslam_ros.tools.evaluation.metrics import (DEFAULT_MAX_GAP, JUMP_THRESHOLD, OSPA_CUTOFF,
                                                   OSPA_ORDER, TrajectoryResult, Transform2D,
                                                   evaluate_trajectory, json_ready,
                                                   landmark_metrics, nees_summary,
                                                   planar_covariances, pose_stamped_series,
                                                   reference_positions)
from fastslam_ros.output import staged_output, write_text

POSE_TOPIC = "/fastslam/pose"
PATH_TOPIC = "/fastslam/path"
MAP_CLOUD_TOPIC = "/fastslam/map_cloud"
DIAGNOSTICS_TOPIC = "/diagnostics"
LANDMARK_MATCHES = ("auto", "id", "assignment")
"""How estimated landmarks are paired with the truth (see ``matches_by_id``)."""


# ---------------------------------------------------------------- loading a run


@dataclass
class LandmarkEstimate:
    """The final map of the best particle (map frame)."""

    positions: np.ndarray
    covariances: np.ndarray
    ids: np.ndarray
    existence: np.ndarray


@dataclass
class RunData:
    """Everything read from a recorded run (and its ground truth)."""

    estimate: PoseSeries | None
    final_path: PoseSeries | None
    odometry: PoseSeries | None
    ground_truth: PoseSeries | None
    landmarks: LandmarkEstimate | None
    landmarks_truth: LandmarkSet | None
    replay_info: dict[str, Any]
    diagnostics: dict[str, str]
    observed_ids: np.ndarray | None = None
    """Labels (>= 0) that appear in the input clouds: the landmarks the robot saw; None when the
    clouds carry no labels."""
    estimate_covariances: np.ndarray | None = None
    """(N, 2, 2) position covariances the estimate claimed, one per ``estimate`` sample."""


def _landmark_estimate(msg: Any) -> LandmarkEstimate:
    fields = cloud_to_arrays(msg)
    count = len(fields.get("x", []))
    positions = np.zeros((0, 2))
    if count:
        positions = np.stack([fields["x"], fields["y"]], axis=1).astype(float)
    covariances = np.zeros((count, 2, 2))
    if {"cov_xx", "cov_xy", "cov_yy"} <= fields.keys():
        covariances[:, 0, 0] = fields["cov_xx"]
        covariances[:, 0, 1] = covariances[:, 1, 0] = fields["cov_xy"]
        covariances[:, 1, 1] = fields["cov_yy"]
    ids = fields["id"].astype(int) if "id" in fields else np.full(count, -1)
    existence = fields["existence"].astype(float) if "existence" in fields else np.ones(count)
    return LandmarkEstimate(positions, covariances, ids, existence)


def _input_labels(msg: Any) -> np.ndarray:
    """The labels of an input landmark cloud; none from a malformed one, which the node
    dropped (and counted) too, so a replay of a bag with bad input can still be scored."""
    try:
        return landmark_cloud_arrays(msg)[1]
    except ValueError:  # SchemaError included: no x/y fields, a buffer that does not fit
        return np.zeros(0, np.int32)


def _odometry_series(messages: list[Any], params: dict[str, Any]) -> PoseSeries | None:
    """Dead reckoning from the recorded odometry, without the messages the node would drop
    on their own: no pose or orientation, another frame than most, a stray or repeated stamp
    (``StampGate``), a jump (``OdometryGate``, with the run's ``max_speed`` and
    ``max_yaw_rate``). A bad message then no longer stops the evaluation; the figure of a bag
    with glitches can still differ from the clean bag's."""
    limits = (float(params.get("max_speed", max_speed_parameter().default)),
              float(params.get("max_yaw_rate", max_yaw_rate_parameter().default)))
    frames = [msg.header.frame_id for msg in messages]
    frame = max(set(frames), key=frames.count) if frames else ""
    gate, clock, stamps, poses, kept = OdometryGate(), StampGate(), [], [], []
    for msg in messages:
        try:
            pose = np.array(odometry_to_pose(msg), float)
        except ValueError:  # a zero or non-finite quaternion
            continue
        stamp = time_msg_to_stamp(msg.header.stamp)
        if (msg.header.frame_id != frame or not np.isfinite(pose).all()
                or np.abs(pose[:2]).max() > MAX_ODOMETRY_COORDINATE
                or clock.check(stamp) == StampGate.OUTLIER or (stamps and stamp <= stamps[-1])):
            continue
        pose = gate.corrected(pose)
        if stamps and gate.check(stamps[-1], poses[-1], stamp, pose,
                                 *limits) == OdometryGate.IMPLAUSIBLE:
            continue
        stamps.append(stamp)
        poses.append(pose)
        kept.append(msg)
    if not kept:
        return None
    return PoseSeries(np.array(stamps), np.array(poses), frame, kept[0].child_frame_id)


def _diagnostic_values(msg: Any) -> dict[str, str]:
    """Every key/value of a DiagnosticArray, flattened (later statuses win)."""
    return {pair.key: pair.value for status in msg.status for pair in status.values}


def load_run(out_path: str | Path, ground_truth_path: str | Path | None = None) -> RunData:
    """Read a recorded run; ground truth and odometry come from ``ground_truth_path`` if given
    (else from ``out_path``)."""
    out_path = Path(out_path)
    if not out_path.exists():
        raise FileNotFoundError(f"bag not found: {out_path}")
    truth_path = Path(ground_truth_path) if ground_truth_path else out_path
    data = read_topics(out_path, [POSE_TOPIC])
    last = read_last(out_path, [PATH_TOPIC, MAP_CLOUD_TOPIC, DIAGNOSTICS_TOPIC, REPLAY_INFO_TOPIC])
    truth_topics = bag_topics(truth_path)
    source = {topic: truth_path if topic in truth_topics else out_path
              for topic in (GROUND_TRUTH_POSE_TOPIC, GROUND_TRUTH_LANDMARKS_TOPIC, ODOM_TOPIC,
                            LANDMARKS_TOPIC, TF_STATIC_TOPIC)}
    series: dict[str, list[Any]] = {}
    for path in set(source.values()):
        topics = [topic for topic, where in source.items() if where == path]
        series.update({topic: messages for topic, (_, messages)
                       in read_topics(path, topics).items()})
    pose_messages = data[POSE_TOPIC][1]
    replay_info = (json.loads(last[REPLAY_INFO_TOPIC][1].data) if REPLAY_INFO_TOPIC in last
                   else {})
    landmarks_truth = None
    if series[GROUND_TRUTH_LANDMARKS_TOPIC]:
        points, ids = landmark_cloud_arrays(series[GROUND_TRUTH_LANDMARKS_TOPIC][-1])
        landmarks_truth = LandmarkSet(points.astype(float), ids)
    labels = [_input_labels(msg) for msg in series[LANDMARKS_TOPIC]]
    observed_ids = np.unique(np.concatenate(labels)) if labels else np.zeros(0, np.int32)
    observed_ids = observed_ids[observed_ids >= 0]
    return RunData(
        estimate=pose_stamped_series(pose_messages) if pose_messages else None,
        final_path=(pose_stamped_series(last[PATH_TOPIC][1].poses)
                    if PATH_TOPIC in last and last[PATH_TOPIC][1].poses else None),
        odometry=_odometry_series(series[ODOM_TOPIC], replay_info.get("params", {})),
        ground_truth=(pose_series_from_messages(series[GROUND_TRUTH_POSE_TOPIC],
                                                series[TF_STATIC_TOPIC])
                      if series[GROUND_TRUTH_POSE_TOPIC] else None),
        landmarks=_landmark_estimate(last[MAP_CLOUD_TOPIC][1]) if MAP_CLOUD_TOPIC in last else None,
        landmarks_truth=landmarks_truth,
        replay_info=replay_info,
        diagnostics=(_diagnostic_values(last[DIAGNOSTICS_TOPIC][1])
                     if DIAGNOSTICS_TOPIC in last else {}),
        observed_ids=observed_ids if len(observed_ids) else None,
        estimate_covariances=planar_covariances(pose_messages))


# ---------------------------------------------------------------- evaluation


@dataclass
class Evaluation:
    """Metrics plus the matched trajectories, for tables and plots."""

    metrics: dict[str, Any]
    run: RunData
    trajectories: dict[str, TrajectoryResult]
    landmark_alignment: Transform2D | None


def matches_by_id(params: dict[str, Any], match: str = "auto") -> bool:
    """Whether landmarks are matched by id: ``match`` is ``id``, ``assignment`` or ``auto``
    (by id unless the run's parameters name an association other than ``known``; a recording
    without them, e.g. from a live node, keeps its ids)."""
    if match not in LANDMARK_MATCHES:
        raise ValueError(f"match must be one of {LANDMARK_MATCHES}, not {match!r}")
    if match != "auto":
        return match == "id"
    return params.get("association", "known") == "known"


def evaluate_run(run: RunData, cutoff: float = OSPA_CUTOFF,
                 max_gap: float = DEFAULT_MAX_GAP, min_existence: float = 0.0,
                 at_base: bool = False, match: str = "auto") -> Evaluation:
    """Compute every metric of a loaded run.

    Poses are compared at the point the ground truth measures (``reference_offset``, e.g. a
    GPS antenna); ``at_base`` compares the robot base instead. ``match`` chooses how
    landmarks are paired with the truth (see ``matches_by_id``)."""
    by_id = matches_by_id(run.replay_info.get("params", {}), match)
    trajectories: dict[str, TrajectoryResult] = {}
    metrics: dict[str, Any] = {}
    if run.ground_truth is not None:
        offset = None if at_base else run.ground_truth.reference_offset
        if offset is not None:
            metrics["reference_point"] = {"frame": run.ground_truth.child_frame_id,
                                          "x": float(offset[0]), "y": float(offset[1])}
        for name, series in (("estimate", run.estimate), ("final_path", run.final_path),
                             ("dead_reckoning", run.odometry)):
            if series is not None and len(series.stamps):
                result = evaluate_trajectory(series.stamps,
                                             reference_positions(series.poses, offset),
                                             run.ground_truth, max_gap)
                if result is not None:
                    trajectories[name] = result
                    metrics[name] = result.metrics()
        if "estimate" in trajectories and run.estimate_covariances is not None:
            metrics["estimate"]["nees"] = _estimate_nees(trajectories["estimate"], run)
    metrics["ground_truth_position_only"] = bool(run.ground_truth is not None
                                                 and run.ground_truth.position_only)
    landmark_alignment = None
    if run.landmarks is not None:
        keep = run.landmarks.existence >= min_existence
        metrics["landmarks_estimated"] = int(np.count_nonzero(keep))
        if run.landmarks_truth is not None:
            source = trajectories.get("final_path") or trajectories.get("estimate")
            landmark_alignment = source.alignment if source else Transform2D()
            positions = run.landmarks.positions[keep]
            ids = run.landmarks.ids[keep]
            truth = run.landmarks_truth
            if run.observed_ids is not None:  # a landmark never seen cannot be missed
                seen = np.isin(truth.ids, run.observed_ids)
                metrics["landmarks_never_observed"] = int(np.count_nonzero(~seen))
                truth = LandmarkSet(truth.positions[seen], truth.ids[seen])
            rotation = landmark_alignment.rotation
            covariances = rotation @ run.landmarks.covariances[keep] @ rotation.T
            metrics["landmarks"] = landmark_metrics(landmark_alignment.apply(positions), ids,
                                                    truth, cutoff, by_id, covariances)
            metrics["landmarks_raw"] = landmark_metrics(positions, ids, truth, cutoff, by_id)
    checked = run.diagnostics.get("associations_checked")
    correct = run.diagnostics.get("associations_correct")
    if checked is not None and correct is not None and int(float(checked)) > 0:
        metrics["association"] = {"checked": int(float(checked)), "correct": int(float(correct)),
                                  "accuracy": float(correct) / float(checked)}
    info = run.replay_info
    if info:
        metrics["runtime"] = {key: info[key] for key in
                              ("wall_time", "cpu_time", "bag_duration", "real_time_factor")
                              if key in info}
        metrics["stats"] = info.get("stats", {})
        metrics["params"] = info.get("params", {})
    return Evaluation(metrics, run, trajectories, landmark_alignment)


def _estimate_nees(result: TrajectoryResult, run: RunData) -> dict[str, Any]:
    """``nees_summary`` of the estimate's aligned errors against the covariances it claimed
    (rotated by the alignment), at the samples the evaluation scored."""
    samples = np.searchsorted(run.estimate.stamps, result.stamps)
    rotation = result.alignment.rotation
    covariances = rotation @ run.estimate_covariances[samples] @ rotation.T
    return nees_summary(result.alignment.apply(result.estimate) - result.reference, covariances)


def evaluate(out_path: str | Path, ground_truth_path: str | Path | None = None,
             cutoff: float = OSPA_CUTOFF, max_gap: float = DEFAULT_MAX_GAP,
             min_existence: float = 0.0, at_base: bool = False,
             match: str = "auto") -> dict[str, Any]:
    """Metrics of a recorded run (JSON-ready).

    Keys, each present when its inputs are: ``estimate``, ``final_path``, ``dead_reckoning``
    (each ``{"raw": {"rmse", "max", "final"}, "aligned": {...}, "alignment": {"yaw", "x", "y"},
    "samples", "jumps": {"threshold", "count", "max_step"}}``, metres); ``landmarks`` (after
    the final path's alignment) and ``landmarks_raw``, each ``{"rmse", "ospa", "matched",
    "missed", "spurious", "estimated", "truth", "match_method", "cutoff"}``;
    ``landmarks_never_observed`` (truth landmarks left out because no input cloud labels them);
    ``landmarks_estimated``; ``association``
    (``{"checked", "correct", "accuracy"}`` from the last ``/diagnostics``); ``runtime``
    (``{"wall_time", "cpu_time", "bag_duration", "real_time_factor"}`` from the replay);
    ``stats`` (node counters); ``params``; ``ground_truth_position_only``.
    """
    run = load_run(out_path, ground_truth_path)
    return evaluate_run(run, cutoff, max_gap, min_existence, at_base, match).metrics


def _number(value: float, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return f"{value:.{digits}f}"


def markdown_table(metrics: dict[str, Any]) -> str:
    """The summary as Markdown: one row per trajectory, then landmarks, association, runtime."""
    lines = ["| trajectory | ATE RMSE (m) | max (m) | final (m) | aligned RMSE (m) | "
             f"aligned max (m) | aligned final (m) | jumps > {JUMP_THRESHOLD:g} m |",
             "|---|---|---|---|---|---|---|---|"]
    labels = {"estimate": "estimate (at the time)", "final_path": "best particle, final path",
              "dead_reckoning": "dead reckoning"}
    for key, label in labels.items():
        if key in metrics:
            raw, aligned = metrics[key]["raw"], metrics[key]["aligned"]
            lines.append(f"| {label} | {_number(raw['rmse'])} | {_number(raw['max'])} | "
                         f"{_number(raw['final'])} | {_number(aligned['rmse'])} | "
                         f"{_number(aligned['max'])} | {_number(aligned['final'])} | "
                         f"{metrics[key]['jumps']['count']} |")
    summary = []
    if "landmarks" in metrics:
        lm = metrics["landmarks"]
        never = metrics.get("landmarks_never_observed", 0)
        unseen = f" ({never} never observed, not counted)" if never else ""
        summary.append(f"| landmarks (aligned) | RMSE {_number(lm['rmse'])} m, OSPA "
                       f"{_number(lm['ospa'])} m (c = {OSPA_CUTOFF:g} m, p = {OSPA_ORDER}), "
                       f"{lm['matched']} matched by {lm['match_method']}, {lm['missed']} missed, "
                       f"{lm['spurious']} spurious of {lm['estimated']}{unseen} |")
    elif "landmarks_estimated" in metrics:
        summary.append(f"| landmarks | {metrics['landmarks_estimated']} in the final map "
                       "(no landmark ground truth) |")
    consistency = [f"{label} median {_number(metrics[key]['nees']['median'], 1)}, "
                   f"{_number(100.0 * metrics[key]['nees']['within_95'], 0)} % within 5.99"
                   for key, label in (("estimate", "pose"), ("landmarks", "landmarks"))
                   if key in metrics and "nees" in metrics[key]]
    if consistency:
        summary.append("| consistency (NEES; consistent: median 1.39, 95 % within 5.99) | "
                       + "; ".join(consistency) + " |")
    if "association" in metrics:
        a = metrics["association"]
        summary.append(f"| association | {100.0 * a['accuracy']:.2f} % correct "
                       f"({a['correct']} of {a['checked']}) |")
    if "runtime" in metrics and "wall_time" in metrics["runtime"]:
        r = metrics["runtime"]
        cpu = f", {r['cpu_time']:.1f} s of CPU" if "cpu_time" in r else ""
        summary.append(f"| runtime | {r['wall_time']:.1f} s for {r['bag_duration']:.1f} s of data, "
                       f"{r['real_time_factor']:.1f}x real time{cpu} |")
    if summary:
        lines += ["", "| | |", "|---|---|"] + summary
    return "\n".join(lines)


TUM_NAMES = {"estimate": "estimate.tum", "final_path": "final_path.tum",
             "dead_reckoning": "dead_reckoning.tum"}
TUM_GROUND_TRUTH = "ground_truth.tum"


def _tum_lines(stamps: np.ndarray, positions: np.ndarray, yaws: np.ndarray) -> str:
    """TUM trajectory text: ``stamp x y z qx qy qz qw`` per line (planar: z = 0)."""
    half = 0.5 * np.asarray(yaws, dtype=float)
    rows = np.column_stack([stamps, positions[:, 0], positions[:, 1], np.zeros(len(stamps)),
                            np.zeros(len(stamps)), np.zeros(len(stamps)), np.sin(half),
                            np.cos(half)])
    return "".join(" ".join(f"{value:.9f}" for value in row) + "\n" for row in rows)


def write_tum(evaluation: Evaluation, folder: str | Path, overwrite: bool = False,
              inputs: Iterable[str | Path] = ()) -> list[Path]:
    """Write the scored trajectories as TUM files for evo (``evo_ape tum ground_truth.tum
    estimate.tum -a``); return the files written.

    Each trajectory file holds the samples the evaluation scored (those with ground truth), at
    the point the ground truth measures; ``ground_truth.tum`` holds the reference interpolated
    at the same stamps, so evo pairs exactly the samples compared here and reports the same
    ATE. ``folder`` is made if missing (its parent must exist); an existing file is replaced
    only with ``overwrite``."""
    folder = Path(folder)
    folder.mkdir(exist_ok=True)
    run = evaluation.run
    series = {"estimate": run.estimate, "final_path": run.final_path,
              "dead_reckoning": run.odometry}
    written = []
    for name, result in evaluation.trajectories.items():
        source = series[name]
        index = np.searchsorted(source.stamps, result.stamps)
        written.append(write_text(folder / TUM_NAMES[name], _tum_lines(
            result.stamps, result.estimate, source.poses[index, 2]), overwrite, inputs))
    if evaluation.trajectories and run.ground_truth is not None:
        results = list(evaluation.trajectories.values())
        stamps = np.concatenate([r.stamps for r in results])
        positions = np.concatenate([r.reference for r in results])
        stamps, first = np.unique(stamps, return_index=True)
        truth = run.ground_truth
        yaws = (np.zeros(len(stamps)) if truth.position_only else
                interpolate_poses(truth.stamps, truth.poses, stamps)[:, 2])
        written.append(write_text(folder / TUM_GROUND_TRUTH,
                                  _tum_lines(stamps, positions[first], yaws), overwrite, inputs))
    return written


def build_parser() -> argparse.ArgumentParser:
    """The ``fastslam-eval`` argument parser."""
    parser = cli.parser("fastslam-eval", __doc__, first_paragraph=True)
    parser.add_argument("out", type=Path,
                        help="bag recorded by fastslam-replay (or ros2 bag record)")
    parser.add_argument("--ground-truth", type=Path, default=None,
                        help="schema bag holding /ground_truth/* and /odom (default: OUT itself)")
    parser.add_argument("--json", type=Path, default=None, help="write the metrics here")
    parser.add_argument("--plot", type=Path, default=None,
                        help="write a figure here (PNG, PDF, SVG)")
    parser.add_argument("--tum", type=Path, default=None, metavar="DIR",
                        help="write the scored trajectories and the ground truth as TUM files "
                             "(estimate.tum, final_path.tum, dead_reckoning.tum, "
                             "ground_truth.tum) into this folder, for evo")
    parser.add_argument("--cutoff", type=cli.positive(float), default=OSPA_CUTOFF,
                        help="landmark match distance (m)")
    parser.add_argument("--max-gap", type=cli.positive(float), default=DEFAULT_MAX_GAP,
                        help="longest ground-truth gap interpolated across (s)")
    parser.add_argument("--min-existence", type=float, default=0.0,
                        help="ignore estimated landmarks with a lower existence probability")
    parser.add_argument("--at-base", action="store_true",
                        help="compare the robot base even when the ground truth measures another "
                             "point of the robot (/tf_static), e.g. to see what that point costs")
    parser.add_argument("--match", choices=LANDMARK_MATCHES, default="auto",
                        help="pair landmarks with the truth by id or by optimal assignment of "
                             "the distances; auto: by id only for a run with known association")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace existing --json / --plot / TUM files (never a folder or an "
                             "input)")
    return parser


@cli.interruptible("fastslam-eval")
def main(argv: list[str] | None = None) -> int:
    """``fastslam-eval``: print the Markdown summary; optionally write JSON, a plot, TUM files."""
    args = build_parser().parse_args(argv)
    prog = "fastslam-eval"
    try:  # a usable bag before any of its topics is read
        cli.input_bag(args.out)
    except cli.UsageError as error:
        return cli.fail(prog, error)
    from fastslam_ros.tools.evaluation import people_eval
    if people_eval.is_people_run(bag_topics(args.out)):
        return people_eval.main(argv)
    inputs = [args.out] + ([args.ground_truth] if args.ground_truth else [])
    written = [args.json, args.plot] + ([args.tum / name for name in TUM_NAMES.values()]
                                        + [args.tum / TUM_GROUND_TRUTH]
                                        if args.tum and args.tum.is_dir() else [])
    suffixes: tuple[str, ...] = ()
    if args.plot is not None:  # matplotlib only when a plot is asked for
        from fastslam_ros.tools.evaluation.plot import plot_formats
        suffixes = plot_formats()
    try:
        if args.tum is not None:
            cli.output_folder(args.tum, "--tum")
        cli.check_scoring_paths(args.out, args.ground_truth, args.json, args.plot, suffixes,
                                [path for path in written if path is not None], args.overwrite)
    except (cli.UsageError, FileExistsError) as error:
        return cli.fail(prog, error)
    try:
        run = load_run(args.out, args.ground_truth)
    except cli.BAG_ERRORS as error:
        return cli.fail(prog, f"cannot evaluate {args.out}: {error}", cli.EXIT_FAILURE)
    if run.estimate is None:
        return cli.fail(prog, f"{args.out} has no {POSE_TOPIC} messages")
    if run.ground_truth is None:
        return cli.fail(prog, f"no {GROUND_TRUTH_POSE_TOPIC} in {args.ground_truth or args.out}")
    evaluation = evaluate_run(run, args.cutoff, args.max_gap, args.min_existence, args.at_base,
                              args.match)
    print(markdown_table(evaluation.metrics))
    try:
        if args.json:
            write_text(args.json, json.dumps(json_ready(evaluation.metrics), indent=2) + "\n",
                       args.overwrite, inputs)
        if args.plot:
            from fastslam_ros.tools.evaluation.plot import plot_evaluation
            with staged_output(args.plot, args.overwrite, "file", inputs) as staged:
                plot_evaluation(evaluation, staged)
        if args.tum:
            write_tum(evaluation, args.tum, args.overwrite, inputs)
    except OSError as error:
        return cli.fail(prog, f"cannot write: {error}", cli.EXIT_USAGE)
    return 0


if __name__ == "__main__":
    sys.exit(main())
