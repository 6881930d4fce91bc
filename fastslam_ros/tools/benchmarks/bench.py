# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""``fastslam-bench``: speed and memory figures of the FastSLAM core (prints them; no asserts).

Four measurements on synthetic worlds (``tools.simulation.synthetic``), single process, on
each ``--backend`` in turn (numpy and, when installed, numba: side by side in one run, so their
ratio holds on a busy machine), timed in wall-clock seconds (the compiled kernels may use
several threads) and, for the throughput, also in CPU seconds of all threads:

* throughput: observations per second for FastSLAM 1.0 / 2.0 with every association rule, M
  particles, about six observations per step; each run is repeated and both the best (the
  least disturbed by other work on the machine, as ``timeit`` reports) and the median are
  printed;
* sweep: time per reading at several M (``--sweep``), FastSLAM 2.0 with ml, and the fit
  a + b M of the median times: the fixed cost a per reading and the cost b per particle;
* scaling: time per observation with N = 100 to 50,000 landmarks already in the map (same
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
from fastslam_ros.core.config import ASSOCIATION_MODES, numba_available
from fastslam_ros.core.landmark_store import STATE_WIDTH
from fastslam_ros.tools import cli
from fastslam_ros.output import check_output, write_text
from fastslam_ros.tools.simulation.synthetic import make_world

LANDMARK_RECORD_BYTES = STATE_WIDTH * 8 + 2 * 8 + 1
"""Bytes of one landmark copy: mean, covariance, log-odds (float64), label, key, occupied."""


def bench_config(algorithm: str, association: str, particles: int, seed: int,
                 max_range: float = 10.0, backend: str = "numpy") -> FastSLAMConfig:
    """The filter configuration every benchmark run uses."""
    return FastSLAMConfig(num_particles=particles, algorithm=algorithm, association=association,
                          sigma_range=0.1, sigma_bearing=0.02, alpha1=0.01, alpha2=0.0005,
                          alpha3=0.01, alpha4=0.001, max_range=max_range,
                          new_landmark_likelihood=1e-3, seed=seed, backend=backend)


def bench_world(seed: int, steps: int):
    """The throughput world: 60 landmarks on 60 m x 60 m, 10 m sensor range."""
    return make_world(seed=seed, num_landmarks=60, extent=60.0, num_steps=steps,
                      max_range=10.0, sigma_range=0.1, sigma_bearing=0.02)


def run_world(slam: FastSLAM, world) -> tuple[float, float]:
    """Feed a world to the filter; return (wall seconds, CPU seconds)."""
    previous = world.steps[0].odometry
    wall, cpu = time.perf_counter(), time.process_time()
    for k, step in enumerate(world.steps[1:]):
        slam.predict(previous, step.odometry)
        previous = step.odometry
        slam.update(step.ranges, step.bearings, step.ids, stamp=float(k))
    return time.perf_counter() - wall, time.process_time() - cpu


def rates(config: FastSLAMConfig, world, repeat: int) -> list[tuple[float, float]]:
    """Observations per wall-clock second and per CPU second (all threads) of ``repeat``
    runs, each with a fresh filter."""
    observations = world.num_observations - len(world.steps[0].ranges)
    result = []
    for _ in range(repeat):
        slam = FastSLAM(config, initial_pose=world.steps[0].truth)
        wall, cpu = run_world(slam, world)
        result.append((observations / wall, observations / cpu))
    return result


def throughput(particles: int, seed: int, steps: int, repeat: int = 3,
               backends=("numpy",), associations=ASSOCIATION_MODES) -> list[dict]:
    """Observations per second (wall), ~6 observations per step, for each algorithm,
    association and backend: best and median of ``repeat`` runs, the backends' runs of one
    configuration alternating, and each backend's median over the first one's, in wall-clock
    time and in CPU time (the CPU ratio is the steadier one on a machine busy with other
    work)."""
    world = bench_world(seed, steps)
    observations = world.num_observations - len(world.steps[0].ranges)
    rows = []
    for algorithm in ("fastslam2", "fastslam1"):
        for association in associations:
            runs: dict[str, list[tuple[float, float]]] = {backend: [] for backend in backends}
            for _ in range(repeat):
                for backend in backends:
                    config = bench_config(algorithm, association, particles, seed,
                                          backend=backend)
                    runs[backend] += rates(config, world, 1)
            wall_reference, cpu_reference = np.median(runs[backends[0]], axis=0)
            for backend in backends:
                wall, cpu = np.array(runs[backend]).T
                rows.append(dict(algorithm=algorithm, association=association,
                                 particles=particles, backend=backend,
                                 observations=observations,
                                 observations_per_step=observations / (len(world.steps) - 1),
                                 runs=repeat, obs_per_s_best=float(wall.max()),
                                 obs_per_s_median=float(np.median(wall)),
                                 speedup=float(np.median(wall) / wall_reference),
                                 obs_per_cpu_s_median=float(np.median(cpu)),
                                 cpu_speedup=float(np.median(cpu) / cpu_reference)))
    return rows


def sweep(particle_counts, seed: int, steps: int, repeat: int, backends) -> tuple[list, list]:
    """Time per reading (FastSLAM 2.0, ml) at each M and backend, alternating backends; and
    per backend the least-squares fit a + b M of the median times (a: fixed cost per reading,
    b: cost per particle)."""
    world = bench_world(seed, steps)
    readings = len(world.steps) - 1
    observations = world.num_observations - len(world.steps[0].ranges)
    rows, fits = [], []
    for particles in particle_counts:
        runs: dict[str, list[float]] = {backend: [] for backend in backends}
        for _ in range(repeat):
            for backend in backends:
                config = bench_config("fastslam2", "ml", particles, seed, backend=backend)
                runs[backend] += [wall for wall, _ in rates(config, world, 1)]
        reference = float(np.median(runs[backends[0]]))
        for backend in backends:
            median = float(np.median(runs[backend]))
            rows.append(dict(particles=particles, backend=backend, obs_per_s_median=median,
                             ms_per_reading=1e3 * observations / median / readings,
                             speedup=median / reference))
    for backend in backends:
        mine = [row for row in rows if row["backend"] == backend]
        m = np.array([row["particles"] for row in mine], float)
        t = np.array([row["ms_per_reading"] for row in mine])
        # Relative residuals (weights 1 / t): the fixed cost is not lost in the large-M times.
        b, a = np.polyfit(m, t, 1, w=1.0 / t) if len(m) > 1 else (np.nan, t[0])
        fits.append(dict(backend=backend, fixed_ms_per_reading=float(a),
                         us_per_particle=1e3 * float(b)))
    return rows, fits


def populate(slam: FastSLAM, positions: np.ndarray) -> None:
    """Give every particle the same map of ``positions`` (shared blocks, one copy)."""
    store = slam.landmarks
    count = len(positions)
    ws = store.gather(np.full((slam.num_particles, 0), -1, np.int64), num_new_slots=count)
    ws.mean[0] = positions
    ws.cov[0] = (0.01, 0.0, 0.01)
    ws.logodds[0] = slam.config.existence_evidence()[0]
    ws.valid[0] = ws.is_new[0] = True
    store.scatter(ws, track_labels=False)
    store.resample(np.zeros(slam.num_particles, dtype=np.int64))


def scaling(particles: int, seed: int, steps: int, sizes=(100, 1000, 10000, 50000),
            backends=("numpy",)) -> list[dict]:
    """Time per observation with N landmarks pre-loaded at constant density."""
    return [row for size in sizes for backend in backends
            for row in _scaling(particles, seed, steps, (size,), backend)]


def _scaling(particles: int, seed: int, steps: int, sizes, backend: str) -> list[dict]:
    density = 60 / 60.0 ** 2
    rows = []
    for size in sizes:
        extent = float(np.sqrt(size / density))
        rng = np.random.default_rng(seed)
        landmarks = rng.uniform(-extent / 2, extent / 2, size=(size, 2))
        # The robot drives a loop among the first 60 landmarks' area; the rest fill the map.
        world = make_world(seed=seed, num_landmarks=60, extent=60.0, num_steps=steps,
                           max_range=10.0, sigma_range=0.1, sigma_bearing=0.02)
        slam = FastSLAM(bench_config("fastslam2", "ml", particles, seed, backend=backend),
                        initial_pose=world.steps[0].truth)
        far = landmarks[np.abs(landmarks).max(axis=1) > 40.0]
        populate(slam, np.concatenate([world.landmarks, far]))
        wall, cpu = run_world(slam, world)
        observations = world.num_observations - len(world.steps[0].ranges)
        rows.append(dict(landmarks=int(len(far) + len(world.landmarks)), particles=particles,
                         backend=backend,
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


@cli.interruptible("fastslam-bench")
def main(argv: list[str] | None = None) -> int:
    """``fastslam-bench``: print (and optionally write) the speed and memory figures."""
    parser = cli.parser("fastslam-bench", __doc__)
    parser.add_argument("--particles", type=cli.positive(int), default=100,
                        help="number of particles M")
    parser.add_argument("--steps", type=cli.positive(int), default=300,
                        help="steps of each synthetic run")
    parser.add_argument("--seed", type=int, default=1, help="seed of the worlds and filters")
    parser.add_argument("--repeat", type=cli.positive(int), default=3,
                        help="runs of each throughput configuration (best and median shown)")
    parser.add_argument("--only", choices=("throughput", "sweep", "scaling", "memory", "soak"),
                        action="append", help="run only these parts (repeatable)")
    parser.add_argument("--backend", choices=("numpy", "numba"), action="append",
                        help="core backends to compare (repeatable; default: numpy and, when "
                             "installed, numba)")
    parser.add_argument("--association", choices=ASSOCIATION_MODES, action="append",
                        help="association rules of the throughput part (repeatable; default: "
                             "all)")
    parser.add_argument("--sweep", type=cli.positive_list, default="10,100,1000",
                        help="comma-separated particle counts of the sweep (default 10,100,1000)")
    parser.add_argument("--threads", type=cli.positive(int), default=None,
                        help="at most this many threads in the compiled kernels")
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing --json file (never a folder)")
    args = parser.parse_args(argv)
    prog = "fastslam-bench"
    if args.json:  # before measuring: a bad path should not cost the run
        try:
            check_output(cli.output_file(args.json, "--json"), args.overwrite, "file")
        except cli.UsageError as error:
            return cli.fail(prog, error)
        except FileExistsError as error:
            return cli.fail(prog, error)
    parts = args.only or ["throughput", "sweep", "scaling", "memory"]
    backends = tuple(args.backend or (("numpy", "numba") if numba_available() else ("numpy",)))
    if "numba" in backends:
        print("compiling the filter's kernels (first start only; later starts load them from "
              "numba's cache) ...", flush=True)
        from fastslam_ros.core import compiled as kernels  # noqa: PLC0415 (optional)
        print(f"numba kernels ready in {kernels.warm_up():.1f} s", flush=True)
        if args.threads is not None:
            kernels.set_threads(args.threads)
    results: dict[str, list[dict]] = {}
    if "throughput" in parts:
        results["throughput"] = throughput(args.particles, args.seed, args.steps, args.repeat,
                                           backends, tuple(args.association or ASSOCIATION_MODES))
        print(markdown("Throughput (observations per second, wall clock)", results["throughput"]),
              flush=True)
    if "sweep" in parts:
        counts = args.sweep
        results["sweep"], results["fit"] = sweep(counts, args.seed, args.steps, args.repeat,
                                                 backends)
        print(markdown("Time per reading over M (FastSLAM 2.0, ml)", results["sweep"]))
        print(markdown("Fit per reading: a + b M", results["fit"]), flush=True)
    if "scaling" in parts:
        results["scaling"] = scaling(args.particles, args.seed, args.steps, backends=backends)
        print(markdown("Cost per observation vs landmarks in the map", results["scaling"]),
              flush=True)
    if "memory" in parts:
        results["memory"] = memory(args.particles, args.seed)
        print(markdown("Landmark store memory and resampling", results["memory"]))
    if "soak" in parts:  # on request only: 10 h of data through the node (tools/benchmarks/soak.py)
        from fastslam_ros.tools.benchmarks.soak import bench_soak
        results["soak"] = bench_soak()
    if args.json:
        write_text(args.json, json.dumps(results, indent=2), args.overwrite)
    return 0


if __name__ == "__main__":
    sys.exit(main())
