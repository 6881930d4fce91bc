# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Map, then localize on the saved map: the map lifecycle measured on simulated runs.

    python3 -m fastslam_ros.tools.benchmarks.localization_bench --seeds 1 2 3 4 5

Per seed: ``fastslam-sim`` drives the loop scenario (world ``seed``, noise ``seed``) and the
node maps it (replayed in-process); its final map is saved as ``~/save_map`` writes it (the
best particle's confirmed landmarks refined by the least squares over its path,
``core.map_refinement``). A second run of the same world (noise seed
``seed + 100``) is replayed with ``map_file`` and ``mode: localization`` twice, each with an
``/initialpose`` at its first message: the known start pose (standard deviations
``--start-sigma`` m and ``--start-yaw-sigma`` rad: the saved map itself is off by up to a few
metres near the start after the loop closure), and a pose off by ``--offset`` m and
``--yaw-offset`` rad, with one such error per standard deviation. Printed: aligned ATE of
the mapping and of the localization run, their ratio, and the time the off-start run takes
to converge (its position within ``--converged`` m of the known-start run's for good); mean
and worst over the seeds.
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader
from std_msgs.msg import Header

from fastslam_ros import ros_io
from fastslam_ros.core.geometry import compose
from fastslam_ros.tools.bags.bag_schema import (INITIAL_POSE_TOPIC, TYPESTORE, open_writer,
                                           write_schema_bag)
from fastslam_ros.tools.evaluation.evaluate import evaluate_run, load_run
from fastslam_ros.tools.bags.replay import replay_bag
from fastslam_ros.tools.simulation.sim import SimConfig, recommended_params, simulate

INITIAL_POSE_TYPE = "geometry_msgs/msg/PoseWithCovarianceStamped"


@dataclass
class SeedResult:
    """Figures of one seed (m, s)."""

    seed: int
    mapping_ate: float
    localization_ate: float
    off_start_ate: float
    convergence_time: float
    """s from the initialpose until the position error stays below the threshold (inf: never)."""

    @property
    def ratio(self) -> float:
        return self.localization_ate / self.mapping_ate


def convergence_time(stamps: np.ndarray, errors: np.ndarray, threshold: float) -> float:
    """Seconds from the first stamp until ``errors`` stay below ``threshold`` (inf: never)."""
    above = np.flatnonzero(errors >= threshold)
    if len(above) == 0:
        return 0.0
    if above[-1] == len(errors) - 1:
        return math.inf
    return float(stamps[above[-1] + 1] - stamps[0])


def with_initial_pose(bag: Path, out: Path, pose: np.ndarray, covariance: np.ndarray) -> Path:
    """A copy of ``bag`` with one ``/initialpose`` (map frame) at its first message."""
    with AnyReader([bag], default_typestore=TYPESTORE) as reader:
        first_ns = min(c.msgcount and reader.start_time for c in reader.connections)
        with open_writer(out) as writer:
            connections = {c.topic: writer.add_connection(c.topic, c.msgtype, typestore=TYPESTORE)
                           for c in reader.connections}
            msg = PoseWithCovarianceStamped(header=Header(
                stamp=ros_io.seconds_to_stamp(first_ns * 1e-9), frame_id="map"))
            msg.pose.pose = ros_io.pose_msg(pose)
            full = np.zeros((6, 6))
            full[np.ix_((0, 1, 5), (0, 1, 5))] = covariance
            msg.pose.covariance = full.ravel().tolist()
            initial = writer.add_connection(INITIAL_POSE_TOPIC, INITIAL_POSE_TYPE,
                                            typestore=TYPESTORE)
            writer.write(initial, first_ns, serialize_message(msg))
            for connection, stamp_ns, raw in reader.messages():
                writer.write(connections[connection.topic], stamp_ns, bytes(raw))
    return out


def run_seed(seed: int, workdir: Path, args: argparse.Namespace) -> SeedResult:
    """The three replays of one seed."""
    duration, offset, yaw_offset = args.duration, args.offset, args.yaw_offset
    mapping_config = SimConfig(seed=seed, world_seed=seed, duration=duration)
    # The filter's own estimate while mapping (docs/localization.md's figures), not the
    # smoother's: localization has no smoother.
    params = {**recommended_params(mapping_config.resolved()), "seed": seed,
              "smoothing_period": 0.0}
    mapping_bag = write_schema_bag(workdir / "mapping", simulate(mapping_config))
    map_file = workdir / "map.yaml"
    saved = replay_bag(mapping_bag, params, out_path=workdir / "mapping_out",
                       save_map=map_file)
    if getattr(args, "verbose", False):
        print(f"seed {seed}: {saved.saved_map}", file=sys.stderr)
    mapping = evaluate_run(load_run(workdir / "mapping_out")).metrics

    second = SimConfig(seed=seed + 100, world_seed=seed, duration=duration)
    second_bag = write_schema_bag(workdir / "second", simulate(second))
    localization = {**params, "map_file": str(map_file), "mode": "localization"}
    start = load_run(second_bag).odometry.poses[0]
    start_covariance = np.diag([args.start_sigma ** 2, args.start_sigma ** 2,
                                args.start_yaw_sigma ** 2])
    known_bag = with_initial_pose(second_bag, workdir / "known_start", start, start_covariance)
    replay_bag(known_bag, localization, out_path=workdir / "known_start_out")
    known = evaluate_run(load_run(workdir / "known_start_out"))

    step = offset / math.sqrt(2.0)
    guess = compose(start, np.array([step, step, yaw_offset]))
    covariance = np.diag([step ** 2, step ** 2, yaw_offset ** 2])
    off_bag = with_initial_pose(second_bag, workdir / "off_start", guess, covariance)
    replay_bag(off_bag, localization, out_path=workdir / "off_start_out")
    off = evaluate_run(load_run(workdir / "off_start_out"))
    # Both runs localize on the same map: the off-start one has converged once it stays with
    # the known-start one (the map's own error is in both).
    ours, theirs = off.trajectories["estimate"], known.trajectories["estimate"]
    other = np.column_stack([np.interp(ours.stamps, theirs.stamps, theirs.estimate[:, axis])
                             for axis in (0, 1)])
    apart = np.hypot(*(ours.estimate[:, :2] - other).T)
    return SeedResult(seed, mapping["estimate"]["aligned"]["rmse"],
                      known.metrics["estimate"]["aligned"]["rmse"],
                      off.metrics["estimate"]["aligned"]["rmse"],
                      convergence_time(ours.stamps, apart, args.converged))


def main(argv: list[str] | None = None) -> int:
    """``python3 -m fastslam_ros.tools.benchmarks.localization_bench``: map, save, localize."""
    parser = argparse.ArgumentParser(
        prog="python3 -m fastslam_ros.tools.benchmarks.localization_bench",
        description=__doc__.splitlines()[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5],
                        help="simulation seeds (world and noise)")
    parser.add_argument("--offset", type=float, default=2.0,
                        help="position error of the initialpose (m)")
    parser.add_argument("--yaw-offset", type=float, default=0.5,
                        help="heading error of the initialpose (rad)")
    parser.add_argument("--start-sigma", type=float, default=1.0,
                        help="position standard deviation of the known start pose (m)")
    parser.add_argument("--start-yaw-sigma", type=float, default=0.2,
                        help="heading standard deviation of the known start pose (rad)")
    parser.add_argument("--converged", type=float, default=0.5,
                        help="distance (m) to the known-start run's estimate within which the "
                             "off-start run has converged")
    parser.add_argument("--duration", type=float, default=0.0,
                        help="seconds of each simulated run (0: the whole route)")
    parser.add_argument("--verbose", action="store_true",
                        help="print what each saved map holds (on stderr)")
    args = parser.parse_args(argv)
    results = []
    print("| seed | mapping ATE (m) | localization ATE (m) | ratio | off-start ATE (m) | "
          "converged after (s) |\n|---|---|---|---|---|---|")
    for seed in args.seeds:
        with tempfile.TemporaryDirectory(prefix="fastslam_localization_") as workdir:
            result = run_seed(seed, Path(workdir), args)
        results.append(result)
        print(f"| {seed} | {result.mapping_ate:.3f} | {result.localization_ate:.3f} | "
              f"{result.ratio:.2f} | {result.off_start_ate:.3f} | "
              f"{result.convergence_time:.1f} |", flush=True)
    for label, pick in (("mean", np.mean), ("worst", np.max)):
        print(f"| {label} | {pick([r.mapping_ate for r in results]):.3f} | "
              f"{pick([r.localization_ate for r in results]):.3f} | "
              f"{pick([r.ratio for r in results]):.2f} | "
              f"{pick([r.off_start_ate for r in results]):.3f} | "
              f"{pick([r.convergence_time for r in results]):.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
