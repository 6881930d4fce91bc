# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""``fastslam-benchmark``: every dataset found -> convert -> replay -> eval, one Markdown table.

Datasets are looked for under ``--datasets`` (default ``../shared/datasets``): MRCLAM folders
(``MRCLAM_Dataset*``, one sequence per robot), Victoria Park (``rfs_slam_txt``) and the Freiburg
course world. Each sequence runs with its shipped parameter file (``config/<family>.yaml``) for
FastSLAM 1.0 and 2.0, known association and the unknown association that file names
(``config``: ``monte_carlo`` for MRCLAM, ``ml`` for the others; Victoria Park has no ids, so no
known association), for every ``--particles`` count and ``--seeds`` seeds. Converted bags are
kept in ``OUT_DIR/bags`` and reused. The table (one row per run, then the mean and worst row of
every group) goes to stdout and to ``OUT_DIR/benchmark.md``, the raw metrics to
``benchmark.json``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fastslam_ros.output import write_text
from fastslam_ros.tools import cli
from fastslam_ros.tools.datasets import convert

FAMILY_CONFIGS = {"mrclam": "mrclam.yaml", "victoria-park": "victoria_park.yaml",
                  "freiburg": "freiburg.yaml"}
SHIPPED_ASSOCIATION = "config"
"""``--associations`` entry meaning the association the sequence's parameter file names."""
QUICK_DURATION = 300.0
"""Seconds of each sequence that ``--quick`` keeps."""


@dataclass(frozen=True)
class Sequence:
    """One bag to run: a dataset (and robot) of a family."""

    kind: str
    name: str
    source: Path
    robot: int = 1
    has_ids: bool = True
    has_ground_truth: bool = True


@dataclass(frozen=True)
class RunSpec:
    """One filter configuration on one sequence."""

    sequence: Sequence
    algorithm: str
    association: str
    particles: int
    seed: int

    @property
    def label(self) -> str:
        return f"{self.algorithm}-{self.association}-M{self.particles}-s{self.seed}"


def default_datasets_dir() -> Path:
    """``$FASTSLAM_DATASETS``, else ``../shared/datasets`` from the current folder."""
    import os

    return Path(os.environ.get("FASTSLAM_DATASETS", "../shared/datasets"))


def config_dir() -> Path:
    """The shipped ``config`` folder: the source tree's, else the installed share folder."""
    source_tree = Path(__file__).resolve().parents[3] / "config"
    if source_tree.is_dir():
        return source_tree
    return Path(sys.prefix) / "share" / "fastslam_ros" / "config"


def discover(roots: list[Path]) -> list[Sequence]:
    """Every dataset sequence under ``roots`` (searched recursively, sorted by name)."""
    found: dict[Path, Sequence] = {}
    for root in roots:
        for odometry in sorted(root.rglob("Robot1_Odometry.dat")):
            folder = odometry.parent
            for robot in range(1, 6):
                if (folder / f"Robot{robot}_Odometry.dat").exists():
                    sequence = Sequence("mrclam", f"{folder.name} R{robot}", folder, robot)
                    found[folder / str(robot)] = sequence
        for inputs in sorted(root.rglob("rfs_slam_txt/inputs.dat")):
            found[inputs.parent] = Sequence("victoria-park", "VictoriaPark", inputs.parent,
                                            has_ids=False)
        for sensor_data in sorted(root.rglob("sensor_data.dat")):
            if (sensor_data.parent / "world.dat").exists():
                found[sensor_data.parent] = Sequence("freiburg", sensor_data.parent.name,
                                                     sensor_data.parent, has_ground_truth=False)
    return list(found.values())


def bag_for(sequence: Sequence, bag_dir: Path, duration: float | None) -> Path:
    """The converted bag of a sequence, converted on first use and reused afterwards."""
    suffix = "" if duration is None else f"_{duration:g}s"
    name = sequence.name.replace(" ", "_") + suffix
    path = bag_dir / name
    if not (path / "metadata.yaml").exists():
        convert.convert(sequence.kind, sequence.source, path, sequence.robot, use_ids=True,
                        duration=duration, overwrite=True)
    return path


def dead_reckoning(bag: Path) -> dict[str, Any] | None:
    """ATE of the odometry itself (raw and aligned RMSE) against the bag's ground truth."""
    from fastslam_ros.tools.bags.bag_schema import read_schema_bag
    from fastslam_ros.tools.evaluation.metrics import evaluate_trajectory

    schema = read_schema_bag(bag)
    if schema.ground_truth is None:
        return None
    result = evaluate_trajectory(schema.odometry.stamps, np.asarray(schema.odometry.poses)[:, :2],
                                 schema.ground_truth)
    return None if result is None else result.metrics()


def run_one(spec: RunSpec, bag: Path, out_dir: Path) -> dict[str, Any]:
    """Replay one configuration through the node and evaluate it; a flat row of metrics."""
    from fastslam_ros.tools.evaluation.evaluate import evaluate
    from fastslam_ros.tools.bags.replay import replay_bag

    out_path = out_dir / "runs" / f"{bag.name}_{spec.label}"
    params = {"algorithm": spec.algorithm, "association": spec.association,
              "num_particles": spec.particles, "seed": spec.seed}
    # The runs folder is the benchmark's own: a rerun replaces its bags (and nothing else).
    result = replay_bag(bag, params=params,
                        params_file=config_dir() / FAMILY_CONFIGS[spec.sequence.kind],
                        out_path=out_path, overwrite=True)
    metrics = evaluate(out_path, ground_truth_path=bag)
    row = {"sequence": spec.sequence.name, "family": spec.sequence.kind,
           "algorithm": spec.algorithm, "association": spec.association,
           "particles": spec.particles, "seed": spec.seed,
           "wall_time": result.wall_time, "bag_duration": result.bag_duration,
           "real_time_factor": result.bag_duration / max(result.wall_time, 1e-9)}
    for key in ("estimate", "final_path"):
        if key in metrics:
            row[f"{key}_raw"] = metrics[key]["raw"]["rmse"]
            row[f"{key}_aligned"] = metrics[key]["aligned"]["rmse"]
    if "estimate" in metrics:
        row["estimate_jumps"] = metrics["estimate"]["jumps"]["count"]
    if "landmarks" in metrics:
        landmarks = metrics["landmarks"]
        row.update(landmark_rmse=landmarks["rmse"], spurious=landmarks["spurious"],
                   missed=landmarks["missed"])
    row["landmarks_estimated"] = metrics.get("landmarks_estimated")
    if "association" in metrics:
        row["association_accuracy"] = metrics["association"]["accuracy"]
    return row


def _cell(value: Any, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


COLUMNS = (("sequence", "sequence", 0), ("algorithm", "algorithm", 0),
           ("association", "assoc.", 0), ("particles", "M", 0), ("seed", "seed", 0),
           ("estimate_raw", "ATE raw (m)", 3), ("estimate_aligned", "ATE aligned (m)", 3),
           ("estimate_jumps", "jumps", 1),
           ("final_path_raw", "final path raw (m)", 3),
           ("final_path_aligned", "final path aligned (m)", 3),
           ("landmark_rmse", "landmark RMSE (m)", 3), ("spurious", "spurious", 1),
           ("missed", "missed", 1), ("wall_time", "runtime (s)", 1),
           ("real_time_factor", "x real time", 1))


def summarize(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean and worst rows of every (dataset, algorithm, association, M) group of 2+ runs."""
    groups: dict[tuple, list[dict[str, Any]]] = {}
    for row in rows:
        dataset = row["sequence"].split(" ")[0]
        groups.setdefault((dataset, row["algorithm"], row["association"], row["particles"]),
                          []).append(row)
    summary = []
    for (dataset, algorithm, association, particles), members in groups.items():
        if len(members) < 2:
            continue
        for label, reduce in (("mean", np.nanmean), ("worst", np.nanmax)):
            row = {"sequence": f"**{dataset} {label}**", "algorithm": algorithm,
                   "association": association, "particles": particles, "seed": "-"}
            for key, _, _ in COLUMNS[5:]:
                values = [m[key] for m in members if isinstance(m.get(key), (int, float))]
                if values:
                    value = float(reduce(values))
                    worst_is_min = key == "real_time_factor" and label == "worst"
                    row[key] = float(np.nanmin(values)) if worst_is_min else value
            summary.append(row)
    return summary


def markdown(rows: list[dict[str, Any]], baselines: dict[str, dict[str, Any]]) -> str:
    """The benchmark table, then dead reckoning per sequence."""
    lines = ["| " + " | ".join(title for _, title, _ in COLUMNS) + " |",
             "|" + "---|" * len(COLUMNS)]
    for row in rows + summarize(rows):
        lines.append("| " + " | ".join(_cell(row.get(key), digits) for key, _, digits in COLUMNS)
                     + " |")
    if baselines:
        lines += ["", "| sequence | dead reckoning ATE raw (m) | aligned (m) |", "|---|---|---|"]
        for name, metrics in baselines.items():
            lines.append(f"| {name} | {_cell(metrics['raw']['rmse'])} | "
                         f"{_cell(metrics['aligned']['rmse'])} |")
    return "\n".join(lines)


def shipped_association(kind: str) -> str:
    """The association named by a family's shipped parameter file."""
    from fastslam_ros.tools.bags.replay import load_params_file

    return load_params_file(config_dir() / FAMILY_CONFIGS[kind]).get("association", "ml")


def plan(sequences: list[Sequence], algorithms: list[str], associations: list[str],
         particles: list[int], seeds: int) -> list[RunSpec]:
    """Every run: the product of the options (``config`` resolved per sequence, each
    association once), without known association where ids are absent."""
    specs = []
    for sequence in sequences:
        resolved = [shipped_association(sequence.kind) if name == SHIPPED_ASSOCIATION else name
                    for name in associations]
        usable = [name for name in dict.fromkeys(resolved) if name != "known" or sequence.has_ids]
        specs += [RunSpec(sequence, algorithm, association, count, seed)
                  for algorithm in algorithms for association in usable
                  for count in particles for seed in range(1, seeds + 1)]
    return specs


def build_parser() -> argparse.ArgumentParser:
    """The ``fastslam-benchmark`` argument parser."""
    parser = cli.parser("fastslam-benchmark", __doc__)
    parser.add_argument("--datasets", type=Path, nargs="+", default=None,
                        help="folders to search (default: $FASTSLAM_DATASETS or "
                             "../shared/datasets)")
    parser.add_argument("--out-dir", type=Path, default=Path("benchmark_results"),
                        help="folder for the converted bags, the runs and the tables")
    parser.add_argument("--particles", type=cli.positive(int), nargs="+", default=[100],
                        help="particle counts")
    parser.add_argument("--algorithms", nargs="+", default=["fastslam1", "fastslam2"],
                        choices=["fastslam1", "fastslam2"], help="FastSLAM versions to run")
    parser.add_argument("--associations", nargs="+", default=["known", SHIPPED_ASSOCIATION],
                        choices=["known", "ml", "monte_carlo", "two_gate", SHIPPED_ASSOCIATION],
                        help="known ids and/or unknown association rules; config: the one the "
                             "sequence's parameter file names")
    parser.add_argument("--seeds", type=cli.positive(int), default=1,
                        help="seeds 1..N per configuration")
    parser.add_argument("--only", default=None,
                        help="run only sequences whose name contains this text")
    parser.add_argument("--quick", action="store_true",
                        help=f"first {QUICK_DURATION:g} s of each sequence, FastSLAM 2.0 only")
    parser.add_argument("--jobs", type=cli.positive(int), default=1,
                        help="parallel runs (runtimes are then measured under load)")
    return parser


def _run_with_bag(job: tuple[RunSpec, Path, Path]) -> dict[str, Any]:
    spec, bag, out_dir = job
    try:
        return run_one(spec, bag, out_dir)
    except Exception as error:  # one failing run must not lose the others
        return {"sequence": spec.sequence.name, "algorithm": spec.algorithm,
                "association": spec.association, "particles": spec.particles,
                "seed": spec.seed, "error": f"{type(error).__name__}: {error}"}


@cli.interruptible("fastslam-benchmark")
def main(argv: list[str] | None = None) -> int:
    """``fastslam-benchmark``: run every dataset found and print the table."""
    args = build_parser().parse_args(argv)
    roots = args.datasets or [default_datasets_dir()]
    sequences = [s for s in discover([r for r in roots if r.exists()])
                 if args.only is None or args.only in s.name]
    if not sequences:
        return cli.fail("fastslam-benchmark",
                        f"no dataset found under {', '.join(map(str, roots))}", cli.EXIT_USAGE)
    algorithms = ["fastslam2"] if args.quick else args.algorithms
    duration = QUICK_DURATION if args.quick else None
    try:
        cli.output_folder(args.out_dir, "--out-dir")
    except cli.UsageError as error:
        return cli.fail("fastslam-benchmark", error)
    for folder in (args.out_dir, args.out_dir / "bags", args.out_dir / "runs"):
        folder.mkdir(exist_ok=True)  # the benchmark's own workspace: converted bags and runs
    try:
        bags = {s: bag_for(s, args.out_dir / "bags", duration) for s in sequences}
        baselines = {s.name: m for s in sequences if (m := dead_reckoning(bags[s])) is not None}
    except (OSError, ValueError) as error:  # a dataset file that does not read
        return cli.fail("fastslam-benchmark", f"cannot convert the datasets: {error}",
                        cli.EXIT_FAILURE)
    specs = plan(sequences, algorithms, args.associations, args.particles, args.seeds)
    jobs = [(spec, bags[spec.sequence], args.out_dir) for spec in specs]
    print(f"fastslam-benchmark: {len(jobs)} runs on {len(sequences)} sequences", file=sys.stderr)
    rows = []
    if args.jobs > 1:
        from multiprocessing import Pool
        with Pool(args.jobs) as pool:
            for row in pool.imap(_run_with_bag, jobs):
                rows.append(row)
                print(f"  done {row['sequence']} {row['algorithm']} {row['association']}",
                      file=sys.stderr)
    else:
        for job in jobs:
            rows.append(_run_with_bag(job))
            print(f"  done {rows[-1]['sequence']} {rows[-1]['algorithm']} "
                  f"{rows[-1]['association']}", file=sys.stderr)
    failed = [row for row in rows if "error" in row]
    table = markdown([row for row in rows if "error" not in row], baselines)
    write_text(args.out_dir / "benchmark.md", table + "\n", overwrite=True)
    write_text(args.out_dir / "benchmark.json", json.dumps(
        {"rows": rows, "dead_reckoning": baselines, "sequences": [
            {**asdict(s), "source": str(s.source)} for s in sequences]}, indent=2, default=str),
        overwrite=True)
    print(table)
    for row in failed:
        print(f"FAILED {row['sequence']} {row['algorithm']} {row['association']}: {row['error']}",
              file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
