"""The main job end to end, no download: simulate the loop, replay it through the node,
evaluate and plot.

``fastslam-demo --out-dir demo`` writes into ``demo/``: ``sim_loop/`` (the input bag),
``sim_loop.yaml`` (the parameters used), ``replay/`` (the recorded outputs),
``metrics.json``, ``summary.md`` and ``result.png``, and prints the summary table.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from fastslam_ros.tools.bag_schema import write_schema_bag
from fastslam_ros.tools.evaluate import evaluate_run, json_ready, load_run, markdown_table
from fastslam_ros.tools.plot import plot_evaluation
from fastslam_ros.tools.replay import replay_bag, summary_lines
from fastslam_ros.tools.sim import (SCENARIOS, SimConfig, recommended_params, simulate,
                                    write_params_yaml)


def run_demo(out_dir: Path, scenario: str = "loop", particles: int = 100, seed: int = 0,
             algorithm: str = "fastslam2", association: str = "ml", duration: float = 0.0,
             progress: bool = False) -> dict:
    """Simulate, replay, evaluate and plot into ``out_dir``; return the metrics."""
    out_dir.mkdir(parents=True, exist_ok=True)
    config = SimConfig(scenario=scenario, seed=seed, duration=duration)
    bag_path = out_dir / f"sim_{scenario}"
    write_schema_bag(bag_path, simulate(config), overwrite=True)
    params = dict(recommended_params(config), num_particles=particles, seed=seed,
                  algorithm=algorithm, association=association)
    params_path = write_params_yaml(out_dir / f"sim_{scenario}.yaml", params,
                                    f"Parameters of fastslam-demo (scenario {scenario}, "
                                    f"seed {seed}).")
    result = replay_bag(bag_path, params_file=params_path, out_path=out_dir / "replay",
                        progress=progress)
    print("\n".join(summary_lines(result)), file=sys.stderr)
    evaluation = evaluate_run(load_run(out_dir / "replay"))
    table = markdown_table(evaluation.metrics)
    (out_dir / "summary.md").write_text(table + "\n")
    (out_dir / "metrics.json").write_text(json.dumps(json_ready(evaluation.metrics), indent=2)
                                          + "\n")
    plot_evaluation(evaluation, out_dir / "result.png",
                    title=f"{scenario}: {algorithm}, {association} association, M = {particles}")
    print(table)
    print(f"\nfiles in {out_dir}: summary.md, metrics.json, result.png, replay/, "
          f"{bag_path.name}/, {params_path.name}")
    return evaluation.metrics


def main(argv: list[str] | None = None) -> int:
    """``fastslam-demo``: the README's main job."""
    parser = argparse.ArgumentParser(prog="fastslam-demo",
                                     description=__doc__.split("\n\n")[0].replace("``", ""))
    parser.add_argument("--out-dir", type=Path, default=Path("fastslam_demo"),
                        help="folder for every output [fastslam_demo]")
    parser.add_argument("--scenario", choices=SCENARIOS + ("people",), default="loop",
                        help="[loop]; people: the people tracker on a known map")
    parser.add_argument("--particles", type=int, default=100, help="number of particles [100]")
    parser.add_argument("--seed", type=int, default=0, help="simulation and filter seed [0]")
    parser.add_argument("--algorithm", choices=("fastslam1", "fastslam2"), default="fastslam2",
                        help="[fastslam2]")
    parser.add_argument("--association", choices=("known", "ml", "monte_carlo", "two_gate"),
                        default="ml", help="data association [ml]")
    parser.add_argument("--duration", type=float, default=0.0,
                        help="simulate only this many seconds (0: the whole route) [0]")
    parser.add_argument("--progress", action="store_true",
                        help="show the replay progress bar even when stderr is not a terminal")
    args = parser.parse_args(argv)
    try:
        if args.scenario == "people":
            from fastslam_ros.tools.people_eval import run_people_demo
            run_people_demo(args.out_dir, args.seed or 1, args.duration or 60.0,
                            args.progress or sys.stderr.isatty())
            return 0
        run_demo(args.out_dir, args.scenario, args.particles, args.seed, args.algorithm,
                 args.association, args.duration, args.progress or sys.stderr.isatty())
    except (ValueError, OSError) as error:
        print(f"fastslam-demo: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
