# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""``fastslam-convert KIND SRC --out BAG``: public datasets -> bag schema v1.

KIND is ``mrclam`` (UTIAS MRCLAM, one robot), ``victoria-park`` (ACFR Victoria Park,
``rfs_slam_txt``) or ``freiburg`` (Freiburg "Robot Mapping" course world). ``--calibrate``
prints what is estimated from the data instead of converting: noise parameters (MRCLAM,
Freiburg) or the GPS antenna's position on the car (Victoria Park).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fastslam_ros.tools import cli
from fastslam_ros.tools.datasets.converters import Recording, freiburg, mrclam, victoria_park

KINDS = ("mrclam", "victoria-park", "freiburg")


def load_recording(kind: str, source: Path | str, robot: int = 1, use_ids: bool = True,
                   odometry: dict | None = None) -> Recording:
    """Parse a dataset folder of the given kind (``odometry``: MRCLAM command corrections,
    keyword arguments of ``mrclam.load_mrclam``)."""
    if kind == "mrclam":
        return mrclam.load_mrclam(source, robot, use_ids=use_ids, **(odometry or {}))
    if kind == "victoria-park":
        return victoria_park.load_victoria_park(source)
    if kind == "freiburg":
        return freiburg.load_freiburg(source)
    raise ValueError(f"kind: must be one of {KINDS} (got {kind!r})")


def convert(kind: str, source: Path | str, out: Path | str, robot: int = 1, use_ids: bool = True,
            duration: float | None = None, storage: str = "mcap", overwrite: bool = False,
            odometry: dict | None = None) -> Recording:
    """Convert a dataset to a schema-v1 bag at ``out``; return the recording written."""
    from fastslam_ros.tools.bags.bag_schema import write_schema_bag
    from fastslam_ros.output import check_output

    check_output(out, overwrite, "bag", inputs=[source])  # before the parsing work
    recording = load_recording(kind, source, robot, use_ids, odometry)
    if duration is not None:
        recording = recording.head(duration)
    if len(recording.odometry_stamps) < 2 or len(recording.scan_stamps) == 0:
        raise ValueError(f"{source}: no run to convert ({len(recording.odometry_stamps)} "
                         f"odometry poses, {len(recording.scan_stamps)} readings)")
    write_schema_bag(out, recording.to_schema_bag(), storage=storage, overwrite=overwrite,
                     inputs=[source])
    return recording


def calibrate(kind: str, source: Path | str) -> dict[str, float]:
    """Parameters estimated from the data (``mrclam``: noise, all robots against Vicon;
    ``victoria-park``: the GPS antenna's position on the car)."""
    if kind == "mrclam":
        return mrclam.calibrate(source)
    if kind == "freiburg":
        return freiburg.calibrate(source)
    return victoria_park.calibrate(source)


def build_parser() -> argparse.ArgumentParser:
    """The ``fastslam-convert`` argument parser."""
    parser = cli.parser("fastslam-convert", __doc__)
    parser.add_argument("kind", choices=KINDS, help="dataset family")
    parser.add_argument("source", type=Path, help="dataset folder (e.g. MRCLAM_Dataset6)")
    parser.add_argument("--out", type=Path, help="output bag folder (required unless --calibrate)")
    parser.add_argument("--robot", type=int, default=1, help="MRCLAM robot number 1-5")
    parser.add_argument("--no-ids", action="store_true",
                        help="write landmark ids as -1 (MRCLAM; Victoria Park never has ids)")
    parser.add_argument("--duration", type=float, default=None,
                        help="keep only the first DURATION seconds")
    parser.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap",
                        help="bag storage format")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing output bag (never another folder or the input)")
    parser.add_argument("--command-delay", type=float, default=mrclam.COMMAND_DELAY,
                        help="MRCLAM: s between a logged command and the motion")
    parser.add_argument("--speed-scale", type=float, default=mrclam.SPEED_SCALE,
                        help="MRCLAM: actual / commanded speed")
    parser.add_argument("--yaw-rate-scale", type=float, default=mrclam.YAW_RATE_SCALE,
                        help="MRCLAM: actual / commanded turn rate")
    parser.add_argument("--calibrate", action="store_true",
                        help="print parameters estimated from the data and exit")
    return parser


@cli.interruptible("fastslam-convert")
def main(argv: list[str] | None = None) -> int:
    """``fastslam-convert``: convert a dataset folder, or print its calibration."""
    prog = "fastslam-convert"
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.out is None and not args.calibrate:
        parser.error("--out is required (unless --calibrate)")
    try:
        cli.input_path(args.source, "dataset folder")
        if args.out is not None:
            cli.output_folder(args.out, "--out")
    except cli.UsageError as error:
        return cli.fail(prog, error)
    try:
        if args.calibrate:
            for name, value in calibrate(args.kind, args.source).items():
                print(f"{name}: {value:.6g}")
            return 0
        recording = convert(args.kind, args.source, args.out, args.robot, not args.no_ids,
                            args.duration, args.storage, args.overwrite,
                            odometry={"delay": args.command_delay,
                                      "speed_scale": args.speed_scale,
                                      "yaw_rate_scale": args.yaw_rate_scale}
                            if args.kind == "mrclam" else None)
    except FileNotFoundError as error:  # a file of the dataset is missing
        return cli.fail(prog, error)
    except (OSError, ValueError) as error:
        return cli.fail(prog, error, cli.EXIT_FAILURE)
    print(recording.summary())
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
