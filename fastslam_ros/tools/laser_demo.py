# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""``fastslam-demo --scenario laser``: raw laser -> landmark extractor -> SLAM, end to end.

The loop world as a pole world (``tools/laser_sim.py``) is simulated with a 270-degree laser
and written without ``/landmarks`` (``sim_laser/``: ``/odom``, ``/scan`` and the ground
truth), so ``fastslam-replay`` runs the extractor ahead of the SLAM node; ``sim_laser.yaml``
holds the parameters of both (for the replay: the SLAM node's recommended ones with the
extractor's noise and a small missed-detection penalty, docs/extractor.md), and the replay,
``metrics.json``, ``summary.md`` and ``result.png`` follow as in the landmark demo.
"""
from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np

from fastslam_ros.tools.bag_schema import LandmarkScans, write_schema_bag
from fastslam_ros.tools.evaluate import evaluate_run, load_run, markdown_table
from fastslam_ros.tools.laser_sim import Laser, scan_records
from fastslam_ros.tools.metrics import json_ready
from fastslam_ros.tools.output import check_output, prepare_output, write_params_yaml
from fastslam_ros.tools.plot import plot_evaluation
from fastslam_ros.tools.replay import replay_bag, summary_lines
from fastslam_ros.tools.sim import SimConfig, build_world, recommended_params, simulate

LASER_SLAM_PARAMS = {"detector": "both", "logodds_missed": -0.05, "sigma_range": 0.05,
                     "sigma_bearing": 0.005}
"""What the laser demo changes from the simulator's recommended parameters (docs/extractor.md:
the extractor's centre error, occluded poles missed for a while)."""


def run_laser_demo(out_dir: Path, seed: int = 1, particles: int = 100, duration: float = 0.0,
                   progress: bool = False, overwrite: bool = False) -> dict:
    """Simulate, replay through extractor and SLAM, evaluate and plot into ``out_dir``; return
    the metrics (outputs checked first, as ``demo.run_demo`` does)."""
    bag_path, params_path = out_dir / "sim_laser", out_dir / "sim_laser.yaml"
    files = [params_path] + [out_dir / name for name in ("summary.md", "metrics.json",
                                                         "result.png")]
    for path, kind in [(bag_path, "bag"), (out_dir / "replay", "bag")] + [(f, "file")
                                                                          for f in files]:
        check_output(path, overwrite, kind)
    out_dir.mkdir(parents=True, exist_ok=True)
    config = SimConfig(seed=seed, duration=duration,
                       field_of_view=Laser().field_of_view).resolved()
    bag = simulate(config)
    extra = scan_records(config, build_world(config), bag)
    no_clouds = LandmarkScans(np.zeros(0), [], [], config.sensor_frame)
    write_schema_bag(bag_path, dataclasses.replace(bag, scans=no_clouds), overwrite=overwrite,
                     extra=extra)
    params = dict(recommended_params(config), num_particles=particles, seed=seed,
                  **LASER_SLAM_PARAMS)
    write_params_yaml(params_path, params,
                      f"Parameters of fastslam-demo --scenario laser (seed {seed}): the SLAM "
                      "node's and the\nextractor's (detector), for fastslam-replay.",
                      overwrite=overwrite)
    result = replay_bag(bag_path, params_file=params_path, out_path=out_dir / "replay",
                        progress=progress, overwrite=overwrite)
    print("\n".join(summary_lines(result)), file=sys.stderr)
    evaluation = evaluate_run(load_run(out_dir / "replay"))
    table = markdown_table(evaluation.metrics)
    prepare_output(out_dir / "summary.md", overwrite, "file").write_text(table + "\n")
    prepare_output(out_dir / "metrics.json", overwrite, "file").write_text(
        json.dumps(json_ready(evaluation.metrics), indent=2) + "\n")
    plot_evaluation(evaluation, prepare_output(out_dir / "result.png", overwrite, "file"),
                    title=f"laser: extractor ({params['detector']}) + FastSLAM, "
                          f"M = {particles}, {math.degrees(config.field_of_view):.0f} deg")
    print(table)
    print(f"\nfiles in {out_dir}: summary.md, metrics.json, result.png, replay/, "
          f"{bag_path.name}/, {params_path.name}")
    return evaluation.metrics
