# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Measure the landmark extractor on the simulated pole world against the known poles.

For each seed the ``fastslam-sim`` loop world is driven (as ``fastslam-sim --laser`` does) and
every laser scan is extracted in memory. A pole counts as fully visible in a scan when it lies
within the laser's range, every beam crossing its outline hits it first, neither beam just
outside the outline hits something nearer by more than ``segment_jump`` (or is the scan's
edge), and it spans at least ``min_beams`` beams (fewer than that no circle fit can take; such
poles are counted apart). A detection is the nearest extracted landmark within ``GATE`` of a
pole; an extracted landmark with no pole within ``GATE`` is false. Prints the detection rate,
false detections per scan, the centre error by range and the time per scan (one core, this
machine: a benchmark, not a pass mark).

Run: ``python3 -m fastslam_ros.tools.evaluation.extractor_eval --seeds 1 2 3 4 5``.
"""
from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from fastslam_ros.extractor import ExtractorSettings, RawScan, extract_landmarks
from fastslam_ros.tools import cli
from fastslam_ros.tools.simulation.laser_sim import (Laser, noisy_scans, pole_world,
                                                     scan_truth_poses)
from fastslam_ros.output import staged_output
from fastslam_ros.tools.simulation.sim import SimConfig, build_world, simulate

GATE = 0.5
"""Largest distance (m) between a detection and its pole."""
RANGE_BINS = (0.0, 5.0, 10.0, 20.0, 30.0)


def visible_poles(laser: Laser, world, pose: np.ndarray, ranges: np.ndarray, pole: np.ndarray,
                  jump: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the poles fully visible from ``pose`` (noise-free ``ranges`` and ``pole``
    hit per beam, from ``Laser.cast``) and the beams each spans."""
    heading = pose[2] + laser.angles
    direction = np.stack([np.cos(heading), np.sin(heading)], axis=1)
    offset = world.centres - pose[:2]
    distance = np.hypot(offset[:, 0], offset[:, 1])
    near = np.flatnonzero(distance + world.radii < laser.max_range)
    along = direction @ offset[near].T
    outline = (np.sum(offset[near] ** 2, axis=1)[None] - along ** 2
               < world.radii[near][None] ** 2) & (along > 0.0)
    keep, spans = [], []
    for column, index in enumerate(near):
        beams = np.flatnonzero(outline[:, column])
        if not len(beams) or beams[0] == 0 or beams[-1] == laser.beams - 1:
            continue
        if not np.all(pole[beams] == index):
            continue
        edges = ranges[[beams[0], beams[-1]]]
        neighbours = ranges[[beams[0] - 1, beams[-1] + 1]]
        if np.any(neighbours < edges - jump):
            continue
        keep.append(index)
        spans.append(len(beams))
    return np.array(keep, dtype=int), np.array(spans, dtype=int)


@dataclasses.dataclass
class Tally:
    """Counts and errors over scans."""

    scans: int = 0
    visible: int = 0
    detected: int = 0
    thin: int = 0
    thin_detected: int = 0
    false: int = 0
    errors: list = dataclasses.field(default_factory=list)
    ranges: list = dataclasses.field(default_factory=list)
    seconds: list = dataclasses.field(default_factory=list)


def evaluate_seed(seed: int, settings: ExtractorSettings, tally: Tally, laser: Laser,
                  reflective_only: bool, duration: float = 0.0, mixed_pixels: float = 0.0
                  ) -> None:
    """Drive seed ``seed``'s loop (``duration`` s; 0: all of it) and add every scan's outcome
    to ``tally``; the scans are those of ``fastslam-sim --laser --mixed-pixels``."""
    config = SimConfig(seed=seed, duration=duration).resolved()
    world = build_world(config)
    bag = simulate(config)
    poles = pole_world(config.world_seed, world.landmarks.positions, world.waypoints)
    stamps, poses = bag.scans.stamps - bag.scans.stamps[0], scan_truth_poses(bag)
    scans = noisy_scans(laser, poles, poses, stamps, config.seed, mixed_pixels)
    for stamp, pose, (ranges, intensities) in zip(stamps, poses, scans):
        truth_ranges, _, hit = laser.cast(poles, pose, float(stamp))
        scan = RawScan(ranges, float(laser.angles[0]), float(laser.angles[1] - laser.angles[0]),
                       0.05, laser.max_range, intensities)
        start = time.perf_counter()
        found = extract_landmarks(scan, settings).landmarks
        tally.seconds.append(time.perf_counter() - start)
        tally.scans += 1
        c, s = np.cos(pose[2]), np.sin(pose[2])
        offset = poles.centres - pose[:2]
        local = np.column_stack([c * offset[:, 0] + s * offset[:, 1],
                                 -s * offset[:, 0] + c * offset[:, 1]])
        points = np.column_stack([found.x, found.y])
        gaps = np.linalg.norm(points[:, None, :] - local[None], axis=2) if len(points) \
            else np.zeros((0, len(local)))
        tally.false += int(np.sum(gaps.min(axis=1, initial=np.inf) > GATE))
        visible, spans = visible_poles(laser, poles, pose, truth_ranges, hit,
                                       settings.segment_jump)
        if reflective_only:
            spans = spans[poles.reflective[visible]]
            visible = visible[poles.reflective[visible]]
        for index, span in zip(visible, spans):
            error = gaps[:, index].min(initial=np.inf)
            if span < settings.min_beams and not reflective_only:
                tally.thin += 1
                tally.thin_detected += int(error <= GATE)
                continue
            tally.visible += 1
            if error <= GATE:
                tally.detected += 1
                tally.errors.append(error)
                tally.ranges.append(float(np.hypot(*local[index])))


def report(tally: Tally, settings: ExtractorSettings) -> str:
    """The measurements as text."""
    errors, ranges = np.array(tally.errors), np.array(tally.ranges)
    ms = 1e3 * np.array(tally.seconds)
    lines = [f"detector {settings.detector}: {tally.scans} scans",
             f"fully visible poles detected: {tally.detected} / {tally.visible} "
             f"({100.0 * tally.detected / max(tally.visible, 1):.1f} %)"]
    if tally.thin:
        lines.append(f"  (poles spanning < {settings.min_beams} beams: {tally.thin_detected} / "
                     f"{tally.thin} detected)")
    lines.append(f"false detections per scan: {tally.false / max(tally.scans, 1):.4f} "
                 f"({tally.false} in all)")
    lines.append("centre error by range: range m | n | mean m | p95 m | share within "
                 "0.03 m + 1 % of range")
    for low, high in zip(RANGE_BINS[:-1], RANGE_BINS[1:]):
        inside = (ranges >= low) & (ranges < high)
        if inside.any():
            within = np.mean(errors[inside] <= 0.03 + 0.01 * ranges[inside])
            lines.append(f"  {low:4.0f}-{high:<4.0f} | {int(inside.sum()):6d} | "
                         f"{errors[inside].mean():.4f} | {np.percentile(errors[inside], 95):.4f}"
                         f" | {100.0 * within:.1f} %")
    lines.append(f"time per {Laser().beams}-beam scan: mean {ms.mean():.3f} ms, median "
                 f"{np.median(ms):.3f} ms, p95 {np.percentile(ms, 95):.3f} ms")
    return "\n".join(lines)


def plot_scan(path: Path, seed: int, index: int, settings: ExtractorSettings,
              laser: Laser) -> None:
    """Draw scan ``index`` of seed ``seed`` in the sensor frame: the returns, the true poles
    (reflector posts orange), walls and cars, and the landmarks extracted (+)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle

    config = SimConfig(seed=seed).resolved()
    world = build_world(config)
    poles = pole_world(config.world_seed, world.landmarks.positions, world.waypoints)
    pose = scan_truth_poses(simulate(config))[index]
    ranges, intensities = laser.scan(poles, pose, np.random.default_rng([seed, 2, index]))
    scan = RawScan(ranges, float(laser.angles[0]), float(laser.angles[1] - laser.angles[0]),
                   0.05, laser.max_range, intensities)
    found = extract_landmarks(scan, settings).landmarks
    c, s = np.cos(pose[2]), np.sin(pose[2])

    def local(points: np.ndarray) -> np.ndarray:
        offset = points - pose[:2]
        return np.column_stack([c * offset[:, 0] + s * offset[:, 1],
                                -s * offset[:, 0] + c * offset[:, 1]])
    figure, axes = plt.subplots(figsize=(8, 7))
    hit = np.isfinite(ranges)
    axes.scatter(ranges[hit] * np.cos(laser.angles[hit]), ranges[hit] * np.sin(laser.angles[hit]),
                 s=2, color="tab:blue", alpha=0.6, label="laser returns")
    for start, end in zip(local(poles.walls[:, :2]), local(poles.walls[:, 2:])):
        axes.plot([start[0], end[0]], [start[1], end[1]], color="tab:brown", linewidth=0.8)
    centres = local(poles.centres)
    for centre, radius, reflective in zip(centres, poles.radii, poles.reflective):
        axes.add_patch(Circle(centre, radius, fill=False, linewidth=0.8,
                              color="tab:orange" if reflective else "black"))
    for reflective, colour, label in ((False, "black", "poles"),
                                      (True, "tab:orange", "reflector posts")):
        chosen = poles.reflective == reflective
        axes.scatter(*centres[chosen].T, s=40, facecolors="none", edgecolors=colour,
                     linewidths=0.8, label=f"true {label}")
    for kind, colour, label in ((False, "tab:green", "circle fits"),
                                (True, "tab:red", "reflectors")):
        chosen = found.reflector == kind
        axes.scatter(found.x[chosen], found.y[chosen], marker="+", s=60, color=colour,
                     label=f"extracted: {label}")
    axes.plot([0.0], [0.0], marker=">", color="tab:purple", markersize=10, label="laser")
    axes.set_xlim(-laser.max_range, laser.max_range)
    axes.set_ylim(-laser.max_range, laser.max_range)
    axes.set_aspect("equal")
    axes.set_xlabel("x (m, sensor frame)")
    axes.set_ylabel("y (m)")
    axes.set_title(f"seed {seed}, scan {index} (walls and cars brown)")
    axes.legend(loc="lower left", fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def main(argv: list[str] | None = None) -> int:
    """Measure the extractor over the given seeds and print the figures."""
    parser = cli.parser("python3 -m fastslam_ros.tools.evaluation.extractor_eval", __doc__,
                        first_paragraph=True)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5],
                        help="simulation seeds (the loop world, its noise)")
    parser.add_argument("--detector", choices=("circles", "reflectors"), default="circles",
                        help="reflectors: only the reflective poles count as visible")
    parser.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE",
                        help="extractor settings other than the defaults")
    parser.add_argument("--mixed-pixels", type=cli.probability, default=0.0, metavar="P",
                        help="scans with mixed pixels, as fastslam-sim --laser --mixed-pixels")
    parser.add_argument("--plot", type=Path, default=None, metavar="PNG",
                        help="instead, draw one scan of the first seed (--scan) into this file")
    parser.add_argument("--scan", type=int, default=300, help="the scan --plot draws")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --plot")
    args = parser.parse_args(argv)
    try:
        values = {}
        types = {field.name: type(field.default)
                 for field in dataclasses.fields(ExtractorSettings)}
        for item in args.set:
            name, _, value = item.partition("=")
            if name not in types:
                raise ValueError(f"unknown setting {name!r}")
            values[name] = types[name](value)
        settings = ExtractorSettings(**{"detector": args.detector, **values}).validate()
    except ValueError as error:
        print(f"extractor_eval: {error}", file=sys.stderr)
        return 2
    if args.plot is not None:
        try:
            with staged_output(args.plot, args.overwrite, "file") as staged:
                plot_scan(staged, args.seeds[0], args.scan, settings, Laser())
        except FileExistsError as error:
            print(f"extractor_eval: {error}", file=sys.stderr)
            return 2
        print(f"wrote {args.plot}")
        return 0
    tally, laser = Tally(), Laser()
    for seed in args.seeds:
        evaluate_seed(seed, settings, tally, laser, args.detector == "reflectors",
                      mixed_pixels=args.mixed_pixels)
    print(report(tally, settings))
    return 0


if __name__ == "__main__":
    sys.exit(main())
