# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""How far the extractor's landmarks lie from the true poles on a simulated laser bag.

On a ``fastslam-sim --laser`` bag: as extracted, deskewed at the true motion over the sweep,
at the odometry's motion over the sweep (what ``landmark_extractor_node`` does) and at the
odometry's motion over the previous reading period (what it does when no odometry covers the
sweep in time). Prints the
mean, median and 95th percentile (m) of the distance from each landmark to the nearest pole
within 1 m, seen from the true pose at the scan's stamp. Usage:

    python3 docs/sweep_errors.py BAG [EVERY]     # every EVERY-th scan (default 5)
"""
import sys

import numpy as np

from fastslam_ros.core.geometry import relative_pose
from fastslam_ros.core.sweep import sweep_duration, sweep_motion
from fastslam_ros.extractor import ExtractorSettings, extract_landmarks
from fastslam_ros.extractor_io import read_scan
from fastslam_ros.node_support.timing import interpolate_poses
from fastslam_ros.tools.bags.bag_schema import read_schema_bag, read_topic, time_msg_to_stamp


def main(bag_path: str, every: int) -> None:
    """Print the three errors of every ``every``-th scan of the bag at ``bag_path``."""
    bag = read_schema_bag(bag_path)
    odometry, truth = bag.odometry, bag.ground_truth
    poles = bag.landmarks_truth.positions
    _, scans = read_topic(bag_path, "/scan")
    period = float(np.median(np.diff(bag.scans.stamps)))
    errors: dict[str, list[float]] = {
        "as extracted": [], "deskewed, true motion": [], "deskewed, odometry over the sweep": [],
        "deskewed, odometry over the previous period": []}
    for msg in scans[::every]:
        scan = read_scan(msg)
        stamp = time_msg_to_stamp(msg.header.stamp)
        sweep = sweep_duration(scan.time_increment, len(scan.ranges))
        at_stamp, after = interpolate_poses(truth.stamps, truth.poses,
                                            np.array([stamp, stamp + sweep]))
        before, now, swept = interpolate_poses(odometry.stamps, odometry.poses,
                                               np.array([stamp - period, stamp, stamp + sweep]))
        seen = np.array([relative_pose(at_stamp, np.append(pole, 0.0))[:2] for pole in poles])
        landmarks = extract_landmarks(scan, ExtractorSettings(detector="both")).landmarks
        still = (0.0, (0.0, 0.0))
        for name, (rate, velocity) in (
                ("as extracted", still),
                ("deskewed, true motion",
                 sweep_motion(at_stamp, after, sweep, np.zeros(3)) if sweep else still),
                ("deskewed, odometry over the sweep",
                 sweep_motion(now, swept, sweep, np.zeros(3)) if sweep else still),
                ("deskewed, odometry over the previous period",
                 sweep_motion(before, now, period, np.zeros(3)))):
            moved = landmarks.at_first_beam(rate, velocity)
            distance = np.hypot(moved.x[:, None] - seen[:, 0], moved.y[:, None] - seen[:, 1])
            nearest = distance.min(axis=1, initial=np.inf)
            errors[name].extend(nearest[nearest < 1.0])
    for name, values in errors.items():
        print(f"{name}: {len(values)} landmarks, mean {np.mean(values):.3f} m, median "
              f"{np.median(values):.3f} m, 95th percentile {np.percentile(values, 95):.3f} m")


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) == 3 else 5)
