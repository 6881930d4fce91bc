"""``fastslam-bench``: speed and memory figures of the FastSLAM core (prints them; no asserts).

Three measurements on synthetic worlds (``fastslam_ros.tools.synthetic``), single process:

* throughput: observations per second for FastSLAM 1.0 / 2.0 with unknown (ml) and known
  association, M particles, about six observations per step; each run is repeated and both
  the best (the least disturbed by other work on the machine, as ``timeit`` reports) and the
  median are printed;
* scaling: time per observation with N = 100, 1,000, 10,000 landmarks already in the map (same
  landmark density, larger world), to show the spatial gating keeps it flat;
* memory and resampling: bytes held by the copy-on-write landmark store and the time of one
  resampling with N = 10,000 and 50,000 landmarks, against M x N landmark copies.
"""
from __future__ import annotations

import json
import sys
import time

import numpy as np

from fastslam_ros.core import FastSLAM, FastSLAMConfig
from fastslam_ros.core.landmark_store import STATE_WIDTH
from fastslam_ros.tools import cli
from fastslam_ros.tools.synthetic import make_world

LANDMARK_RECORD_BYTES = STATE_WIDTH * 8 + 2 * 8 + 1
"""Bytes of one landmark copy: mean, covariance, log-odds (float64), label, key, occupied."""


def bench_config(algorithm: str, association: str, particles: int, seed: int,
                 max_range: float = 10.0) -> FastSLAMConfig:
    """The filter configuration every benchmark run uses."""
    return FastSLAMConfig(num_particles=particles, algorithm=algorithm, association=association,
                          sigma_range=0.1, sigma_bearing=0.02, alpha1=0.01, alpha2=0.0005,
                          alpha3=0.01, alpha4=0.001, max_range=max_range,
                          new_landmark_likelihood=1e-3, seed=seed)


def run_world(slam: FastSLAM, world) -> tuple[float, float]:
    """Feed a world to the filter; return (wall seconds, CPU seconds)."""
    previous = world.steps[0].odometry
    wall, cpu = time.perf_counter(), time.process_time()
    for k, step in enumerate(world.steps[1:]):
        slam.predict(previous, step.odometry)
        previous = step.odometry
        slam.update(step.ranges, step.bearings, step.ids, stamp=float(k))
    return time.perf_counter() - wall, time.process_time() - cpu


def throughput(particles: int, seed: int, steps: int, repeat: int = 3) -> list[dict]:
    """Observations per second (CPU time), ~6 observations per step, for each
    algorithm/association: best and median of ``repeat`` runs."""
    world = make_world(seed=seed, num_landmarks=60, extent=60.0, num_steps=steps,
                       max_range=10.0, sigma_range=0.1, sigma_bearing=0.02)
    observations = world.num_observations - len(world.steps[0].ranges)
    rows = []
    for algorithm in ("fastslam2", "fastslam1"):
        for association in ("ml", "known"):
            rates = []
            for _ in range(repeat):
                slam = FastSLAM(bench_config(algorithm, association, particles, seed),
                                initial_pose=world.steps[0].truth)
                _, cpu = run_world(slam, world)
                rates.append(observations / cpu)
            rows.append(dict(algorithm=algorithm, association=association, particles=particles,
                             observations=observations,
                             observations_per_step=observations / (len(world.steps) - 1),
                             runs=repeat, obs_per_s_best=max(rates),
                             obs_per_s_median=float(np.median(rates))))
    return rows


def populate(slam: FastSLAM, positions: np.ndarray) -> None:
    """Give every particle the same map of ``positions`` (shared blocks, one copy)."""
    store = slam.landmarks
    count = len(positions)
    ws = store.gather(np.full((slam.num_particles, 0), -1, np.int64), num_new_slots=count)
    ws.mean[0] = positions
    ws.cov[0] = (0.01, 0.0, 0.01)
    ws.logodds[0] = slam.config.logodds_observed
    ws.valid[0] = ws.is_new[0] = True
    store.scatter(ws, track_labels=False)
    store.resample(np.zeros(slam.num_particles, dtype=np.int64))


def scaling(particles: int, seed: int, steps: int, sizes=(100, 1000, 10000)) -> list[dict]:
    """Time per observation with N landmarks pre-loaded at constant density."""
    density = 60 / 60.0 ** 2
    rows = []
    for size in sizes:
        extent = float(np.sqrt(size / density))
        rng = np.random.default_rng(seed)
        landmarks = rng.uniform(-extent / 2, extent / 2, size=(size, 2))
        # The robot drives a loop among the first 60 landmarks' area; the rest fill the map.
        world = make_world(seed=seed, num_landmarks=60, extent=60.0, num_steps=steps,
                           max_range=10.0, sigma_range=0.1, sigma_bearing=0.02)
        slam = FastSLAM(bench_config("fastslam2", "ml", particles, seed),
                        initial_pose=world.steps[0].truth)
        far = landmarks[np.abs(landmarks).max(axis=1) > 40.0]
        populate(slam, np.concatenate([world.landmarks, far]))
        wall, cpu = run_world(slam, world)
        observations = world.num_observations - len(world.steps[0].ranges)
        rows.append(dict(landmarks=int(len(far) + len(world.landmarks)), particles=particles,
                         us_per_observation_wall=1e6 * wall / observations,
                         us_per_observation_cpu=1e6 * cpu / observations))
    return rows


def memory(particles: int, seed: int, sizes=(10000, 50000), steps: int = 100) -> list[dict]:
    """Store bytes and resampling time after some updates (copy-on-write in action)."""
    rows = []
    for size in sizes:
        extent = float(np.sqrt(size / (60 / 60.0 ** 2)))
        rng = np.random.default_rng(seed)
        world = make_world(seed=seed, num_landmarks=60, extent=60.0, num_steps=steps,
                           max_range=10.0, sigma_range=0.1, sigma_bearing=0.02)
        others = rng.uniform(-extent / 2, extent / 2, size=(size - 60, 2))
        slam = FastSLAM(bench_config("fastslam2", "ml", particles, seed),
                        initial_pose=world.steps[0].truth)
        populate(slam, np.concatenate([world.landmarks, others]))
        run_world(slam, world)
        slam.flush()
        indices = np.sort(rng.integers(0, particles, particles))
        start = time.perf_counter()
        repeats = 20
        for _ in range(repeats):
            # The filter defers the reindexing to its next working-set change; time both.
            slam.landmarks.resample(indices)
            slam.landmarks.apply_resampling()
        resample_ms = 1e3 * (time.perf_counter() - start) / repeats
        store_bytes = slam.landmarks.nbytes()
        full_copies = particles * size * LANDMARK_RECORD_BYTES
        rows.append(dict(landmarks=size, particles=particles, store_mib=store_bytes / 2 ** 20,
                         full_copies_mib=full_copies / 2 ** 20,
                         ratio=store_bytes / full_copies, resample_ms=resample_ms,
                         distinct_blocks=slam.landmarks.rows_in_use()))
    return rows


def markdown(title: str, rows: list[dict]) -> str:
    """A Markdown table of result rows under a heading."""
    if not rows:
        return ""
    keys = list(rows[0])

    def cell(value) -> str:
        return f"{value:.4g}" if isinstance(value, float) else str(value)
    lines = [f"### {title}", "", "| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(cell(row[k]) for k in keys) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """``fastslam-bench``: print (and optionally write) the speed and memory figures."""
    parser = cli.parser("fastslam-bench", __doc__)
    parser.add_argument("--particles", type=int, default=100, help="number of particles M")
    parser.add_argument("--steps", type=int, default=300, help="steps of each synthetic run")
    parser.add_argument("--seed", type=int, default=1, help="seed of the worlds and filters")
    parser.add_argument("--repeat", type=int, default=3,
                        help="runs of each throughput configuration (best and median shown)")
    parser.add_argument("--only", choices=("throughput", "scaling", "memory", "soak"),
                        action="append",
                        help="run only these parts (repeatable)")
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    args = parser.parse_args(argv)
    parts = args.only or ["throughput", "scaling", "memory"]
    results: dict[str, list[dict]] = {}
    if "throughput" in parts:
        results["throughput"] = throughput(args.particles, args.seed, args.steps, args.repeat)
        print(markdown("Throughput (observations per second, one core)", results["throughput"]))
    if "scaling" in parts:
        results["scaling"] = scaling(args.particles, args.seed, args.steps)
        print(markdown("Cost per observation vs landmarks in the map", results["scaling"]))
    if "memory" in parts:
        results["memory"] = memory(args.particles, args.seed)
        print(markdown("Landmark store memory and resampling", results["memory"]))
    if "soak" in parts:  # on request only: 10 h of data through the node (tools/soak.py)
        from fastslam_ros.tools.soak import bench_soak
        results["soak"] = bench_soak()
    if args.json:
        with open(args.json, "w", encoding="utf-8") as handle:
            json.dump(results, handle, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
