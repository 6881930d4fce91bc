# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The main job end to end, no download: simulate the loop, replay it through the node,
evaluate and plot.

``fastslam-demo --out-dir demo`` writes into ``demo/``: ``sim_loop/`` (the input bag),
``sim_loop.yaml`` (the parameters used), ``replay/`` (the recorded outputs),
``metrics.json``, ``summary.md`` and ``result.png``, and prints the summary table.
``--scenario laser`` simulates the loop as a pole world seen by a 2-D laser and writes it
without ``/landmarks``, so the replay runs the landmark extractor ahead of the SLAM node
(``sim_laser.yaml`` holds the parameters of both, docs/extractor.md).
"""
from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np

from fastslam_ros.tools import cli
from fastslam_ros.tools.bags.bag_schema import LandmarkScans, SchemaBag, write_schema_bag
from fastslam_ros.tools.evaluation.evaluate import evaluate_run, load_run, markdown_table
from fastslam_ros.tools.evaluation.metrics import json_ready
from fastslam_ros.output import (all_or_nothing, check_output, staged_output, write_params_yaml,
                                 write_text)
from fastslam_ros.tools.evaluation.plot import plot_evaluation
from fastslam_ros.tools.bags.replay import replay_bag, summary_lines
from fastslam_ros.tools.simulation.laser_sim import Laser, scan_records
from fastslam_ros.tools.simulation.sim import (SCENARIOS, SimConfig, build_world,
                                               recommended_params, simulate)

LASER_SLAM_PARAMS = {"detector": "both", "logodds_missed": -0.05, "sigma_range": 0.05,
                     "sigma_bearing": 0.005}
"""What the laser demo changes from the simulator's recommended parameters (docs/extractor.md:
the extractor's centre error, occluded poles missed for a while)."""


def simulated_world(scenario: str, seed: int, duration: float
                    ) -> tuple[SimConfig, SchemaBag, list, dict]:
    """The demo's simulation: its config, the bag, extra records (``/scan`` for ``laser``,
    whose bag then has no ``/landmarks``) and the parameters that differ from the recommended
    ones."""
    if scenario != "laser":
        config = SimConfig(scenario=scenario, seed=seed, duration=duration)
        return config, simulate(config), [], {}
    config = SimConfig(seed=seed, duration=duration,
                       field_of_view=Laser().field_of_view).resolved()
    bag = simulate(config)
    extra = scan_records(config, build_world(config), bag)
    no_clouds = LandmarkScans(np.zeros(0), [], [], config.sensor_frame)
    return config, dataclasses.replace(bag, scans=no_clouds), extra, LASER_SLAM_PARAMS


def run_demo(out_dir: Path, scenario: str = "loop", particles: int = 100, seed: int = 0,
             algorithm: str = "fastslam2", association: str = "ml", duration: float = 0.0,
             progress: bool = False, overwrite: bool = False) -> dict:
    """Simulate, replay, evaluate and plot into ``out_dir``; return the metrics.

    Every output is checked before anything is written: an existing one is replaced only with
    ``overwrite`` (``FileExistsError`` otherwise), and only if it is a bag or a file as the
    demo writes it."""
    bag_path = out_dir / f"sim_{scenario}"
    params_path = out_dir / f"sim_{scenario}.yaml"
    files = [params_path] + [out_dir / name for name in ("summary.md", "metrics.json",
                                                         "result.png")]
    for path, kind in [(bag_path, "bag"), (out_dir / "replay", "bag")] + [(f, "file")
                                                                          for f in files]:
        if out_dir.is_dir():
            check_output(path, overwrite, kind)
    with all_or_nothing([out_dir, bag_path, out_dir / "replay"] + files):
        out_dir.mkdir(exist_ok=True)
        return _demo_outputs(out_dir, bag_path, params_path, overwrite, progress,
                             (scenario, particles, seed, algorithm, association, duration))


def _demo_outputs(out_dir: Path, bag_path: Path, params_path: Path, overwrite: bool,
                  progress: bool, run: tuple) -> dict:
    """``run_demo``'s work once its outputs are checked."""
    scenario, particles, seed, algorithm, association, duration = run
    config, bag, extra, changed = simulated_world(scenario, seed, duration)
    write_schema_bag(bag_path, bag, overwrite=overwrite, extra=extra)
    params = dict(recommended_params(config), num_particles=particles, seed=seed,
                  algorithm=algorithm, association=association, **changed)
    write_params_yaml(params_path, params,
                      f"Parameters of fastslam-demo (scenario {scenario}, seed {seed}).",
                      overwrite=overwrite)
    result = replay_bag(bag_path, params_file=params_path, out_path=out_dir / "replay",
                        progress=progress, overwrite=overwrite)
    print("\n".join(summary_lines(result)), file=sys.stderr)
    evaluation = evaluate_run(load_run(out_dir / "replay"))
    table = markdown_table(evaluation.metrics)
    write_text(out_dir / "summary.md", table + "\n", overwrite)
    write_text(out_dir / "metrics.json", json.dumps(json_ready(evaluation.metrics), indent=2)
               + "\n", overwrite)
    with staged_output(out_dir / "result.png", overwrite, "file") as staged:
        plot_evaluation(evaluation, staged,
                        title=f"{scenario}: {algorithm}, {association} association, "
                              f"M = {particles}, {math.degrees(config.field_of_view):.0f} deg")
    print(table)
    print(f"\nfiles in {out_dir}: summary.md, metrics.json, result.png, replay/, "
          f"{bag_path.name}/, {params_path.name}")
    return evaluation.metrics


@cli.interruptible("fastslam-demo")
def main(argv: list[str] | None = None) -> int:
    """``fastslam-demo``: the README's main job."""
    parser = cli.parser("fastslam-demo", __doc__)
    parser.add_argument("--out-dir", type=Path, default=Path("demo"),
                        help="folder for every output")
    parser.add_argument("--scenario", choices=SCENARIOS + ("people", "laser"), default="loop",
                        help="simulated world and route; people: the people tracker on a known "
                             "map; laser: the loop as a pole world seen by a 2-D laser, "
                             "through the landmark extractor")
    parser.add_argument("--particles", type=int, default=100, help="number of particles")
    parser.add_argument("--seed", type=int, default=0, help="simulation and filter seed")
    parser.add_argument("--algorithm", choices=("fastslam1", "fastslam2"), default="fastslam2",
                        help="FastSLAM 1.0 or 2.0")
    parser.add_argument("--association", choices=("known", "ml", "monte_carlo", "two_gate"),
                        default="ml", help="data association")
    parser.add_argument("--duration", type=float, default=0.0,
                        help="simulate only this many seconds (0: the whole route)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace the outputs of an earlier demo in --out-dir")
    parser.add_argument("--progress", action="store_true",
                        help="show the replay progress bar even when stderr is not a terminal")
    args = parser.parse_args(argv)
    try:
        cli.output_folder(args.out_dir, "--out-dir")
    except cli.UsageError as error:
        return cli.fail("fastslam-demo", error)
    try:
        if args.scenario == "people":
            from fastslam_ros.tools.evaluation.people_eval import run_people_demo
            run_people_demo(args.out_dir, args.seed or 1, args.duration or 60.0,
                            args.progress or sys.stderr.isatty(), args.overwrite)
            return 0
        seed = (args.seed or 1) if args.scenario == "laser" else args.seed
        run_demo(args.out_dir, args.scenario, args.particles, seed, args.algorithm,
                 args.association, args.duration, args.progress or sys.stderr.isatty(),
                 args.overwrite)
    except (ValueError, OSError) as error:
        return cli.fail("fastslam-demo", error, cli.EXIT_FAILURE)
    return 0


if __name__ == "__main__":
    sys.exit(main())
