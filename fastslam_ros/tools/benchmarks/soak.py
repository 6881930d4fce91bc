# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Soak benchmark: hours of simulated data through the real node; memory and output costs.

The simulated loop is driven lap after lap (odometry at 10 Hz, clouds at 2 Hz, so hours of data
take minutes) and fed to ``FastSLAMNode``'s callbacks as ``fastslam-replay`` does. Every hour
of data it prints the process RSS and, at the first and the last hour, the cost of building and
serializing each output once (what one publish costs the callback thread). Run it as
``fastslam-bench --only soak`` or ``python3 -m fastslam_ros.tools.benchmarks.soak --hours
10``. Figures, no asserts.
"""
from __future__ import annotations

import json
import sys
import time
from typing import Any, Callable

import numpy as np
import rclpy
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from rclpy.time import Time
from std_msgs.msg import Header

from fastslam_ros import ros_io
from fastslam_ros.node import FastSLAMNode
from fastslam_ros.tools import cli
from fastslam_ros.output import check_output, write_text
from fastslam_ros.tools.bags.in_process import in_process, isolated_context
from fastslam_ros.tools.simulation.sim import SimConfig, recommended_params, simulate

OUTPUTS = ("pose", "path", "particles", "map", "diagnostics")
"""The node's outputs, as its publish methods group them (map: ~/landmarks and ~/map_cloud;
pose: ~/pose and ~/map_to_odom)."""
PUBLISH_REPEATS = 15


def rss_mib() -> float:
    """Resident set size of this process (MiB), from /proc."""
    with open("/proc/self/statm", encoding="ascii") as stream:
        pages = int(stream.read().split()[1])
    return pages * 4096 / 2**20


def publish_costs(node: FastSLAMNode) -> dict[str, float]:
    """Milliseconds to build and serialize each output once (best of PUBLISH_REPEATS)."""
    def serialize(_topic: str, msg: Any) -> None:
        serialize_message(msg)
    node.output_listeners.append(serialize)
    methods: dict[str, Callable[[], None]] = {
        "pose": node._publish_pose, "path": node._publish_path,
        "particles": node._publish_particles, "map": node._publish_map,
        "diagnostics": node._publish_diagnostics}
    costs = {}
    try:
        for name in OUTPUTS:
            best = float("inf")
            for _ in range(PUBLISH_REPEATS):
                node._map_dirty = True
                start = time.perf_counter()
                methods[name]()
                best = min(best, time.perf_counter() - start)
            costs[name] = 1e3 * best
    finally:
        node.output_listeners.remove(serialize)
    return costs


def soak(hours: float = 10.0, particles: int = 10, seed: int = 1,
         progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Feed ``hours`` of simulated data; RSS per hour and publish costs at the first and last."""
    config = SimConfig(seed=seed, laps=int(hours * 3600 / 150) + 2, duration=hours * 3600,
                       control_rate=10.0, observation_rate=2.0)
    bag = simulate(config)
    params = dict(recommended_params(config), num_particles=particles, seed=seed,
                  use_sim_time=True)
    odometry = bag.odometry
    scans = bag.scans
    context = isolated_context()
    node = in_process(FastSLAMNode)(context=context, enable_rosout=False, parameter_overrides=[
        Parameter(name, value=value) for name, value in params.items()])
    clock = node.get_clock()
    rows, costs = [], {}
    next_hour, scan = 1, 0
    start = time.perf_counter()
    try:
        for stamp, pose in zip(odometry.stamps, odometry.poses):
            while scan < len(scans.stamps) and scans.stamps[scan] <= stamp:
                clock.set_ros_time_override(Time(nanoseconds=round(scans.stamps[scan] * 1e9)))
                node.on_landmarks(ros_io.landmark_cloud(
                    Header(stamp=ros_io.seconds_to_stamp(scans.stamps[scan]),
                           frame_id=scans.frame_id), scans.points[scan], scans.ids[scan]))
                scan += 1
            clock.set_ros_time_override(Time(nanoseconds=round(stamp * 1e9)))
            msg = Odometry(header=Header(stamp=ros_io.seconds_to_stamp(stamp),
                                         frame_id=odometry.frame_id),
                           child_frame_id=odometry.child_frame_id)
            msg.pose.pose = ros_io.pose_msg(pose)
            node.on_odometry(msg)
            if stamp >= next_hour * 3600.0:
                row = {"hour": next_hour, "rss_mib": rss_mib(),
                       "landmarks": len(node.slam.best_map()),
                       "path_poses": len(node.slam.best_path()[0]),
                       "wall_s": time.perf_counter() - start}
                if next_hour == 1 or next_hour >= int(hours):
                    costs[next_hour] = publish_costs(node)
                rows.append(row)
                if progress:
                    progress(f"hour {next_hour}: RSS {row['rss_mib']:.1f} MiB, "
                             f"{row['landmarks']} landmarks, {row['wall_s']:.0f} s")
                next_hour += 1
        stats = dict(node.stats)
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    growth = None
    if len(rows) >= 2:
        hours_axis = np.array([r["hour"] for r in rows], float)
        growth = float(np.polyfit(hours_axis, [r["rss_mib"] for r in rows], 1)[0])
    return {"hours": rows, "publish_ms": costs, "rss_growth_mib_per_hour": growth,
            "particles": particles, "stats": stats}


def report(result: dict[str, Any]) -> str:
    """Markdown: RSS per hour, its growth, and each output's cost at the first and last hour."""
    lines = ["### Soak: RSS per hour of simulated data", "",
             "| hour | RSS (MiB) | landmarks | path poses | wall (s) |", "|---|---|---|---|---|"]
    lines += [f"| {r['hour']} | {r['rss_mib']:.1f} | {r['landmarks']} | {r['path_poses']} | "
              f"{r['wall_s']:.0f} |" for r in result["hours"]]
    if result["rss_growth_mib_per_hour"] is not None:
        lines += ["", f"RSS growth: {result['rss_growth_mib_per_hour']:.2f} MiB per hour of data "
                      "(least squares over the hours, after the first)"]
    costs = result["publish_ms"]
    if costs:
        first, last = min(costs), max(costs)
        lines += ["", f"### Soak: publish cost (ms, build + serialize, best of "
                      f"{PUBLISH_REPEATS})", "",
                  f"| output | hour {first} | hour {last} | ratio |", "|---|---|---|---|"]
        lines += [f"| {name} | {costs[first][name]:.3f} | {costs[last][name]:.3f} | "
                  f"{costs[last][name] / max(costs[first][name], 1e-9):.2f} |"
                  for name in OUTPUTS]
    return "\n".join(lines) + "\n"


def bench_soak(hours: float = 10.0) -> dict[str, Any]:
    """``fastslam-bench --only soak``: run, print the report, return the figures."""
    result = soak(hours, progress=lambda line: print(line, file=sys.stderr, flush=True))
    print(report(result))
    return result


def main(argv: list[str] | None = None) -> int:
    """``python3 -m fastslam_ros.tools.benchmarks.soak``: hours of simulated data through the
    node."""
    parser = cli.parser("python3 -m fastslam_ros.tools.benchmarks.soak", __doc__,
                        first_paragraph=True)
    parser.add_argument("--hours", type=float, default=10.0, help="hours of simulated data")
    parser.add_argument("--particles", type=int, default=10, help="number of particles M")
    parser.add_argument("--seed", type=int, default=1, help="seed of the world and the filter")
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --json")
    args = parser.parse_args(argv)
    if args.json:
        try:
            check_output(args.json, args.overwrite, "file")
        except FileExistsError as error:
            print(f"soak: {error}", file=sys.stderr)
            return 1
    result = soak(args.hours, args.particles, args.seed,
                  progress=lambda line: print(line, file=sys.stderr, flush=True))
    print(report(result))
    if args.json:
        write_text(args.json, json.dumps(result, indent=2, default=str), args.overwrite)
    return 0


if __name__ == "__main__":
    sys.exit(main())
