# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Where a people run's errors are: its misses and the benchmark count's false positives.

Over the frames ``fastslam-eval`` scores (the people the laser sees, people hidden behind
people not scored), a person with no published track within the match radius (0.5 m) is a
miss; each is told apart by the time since the person came into view (at most 0.5 s) and its
distance from the robot (beyond 6 m). Over the benchmark count's frames (every scan, the
people it counts, every published track), a track with no counted person within its radius
(0.75 m) is a false positive; each is told apart by the distance to the nearest person in the
world, counted or not (within 0.3 m: a person the count leaves out, hidden behind another or
with the centre out of view). Prints the sums over the runs given. Usage:

    python3 docs/people_errors.py OUT [OUT ...]     # fastslam-replay outputs of people bags
"""
import sys

import numpy as np

from fastslam_ros.tools.evaluation import people_eval as pe

NEW_IN_VIEW = 0.5
"""A person counts as just come into view this long (s) after it was last out of view."""
FAR = 6.0
"""A person counts as far beyond this range (m) from the robot."""


def errors(path: str) -> dict[str, int]:
    """The error counts of one recorded run."""
    run = pe.read_people_run(path)
    counts = dict.fromkeys(("misses", "new_in_view", "far", "false_positives",
                            "near_a_person_left_out", "within_0.75", "far_from_everyone"), 0)
    by_stamp = {round(f.stamp / pe.FRAME_TOLERANCE): f for f in run.estimate_frames}
    came_into_view, last_seen = {}, {}
    scan_period = float(np.median(np.diff([f.stamp for f in run.truth_frames])))
    for frame in run.truth_frames:
        estimate = by_stamp.get(round(frame.stamp / pe.FRAME_TOLERANCE))
        if estimate is None:
            continue
        pose = pe.pose_at(run.truth, frame.stamp)
        published = estimate.positions[pe.published(estimate, 0.5)]
        truth, tracks = pe.in_view(run.grid, pose, frame, estimate, run.view, 0.5)
        truth, tracks = pe.without_hidden(truth, tracks, pe.hidden_by_people(pose, truth.positions))
        for ident, position in zip(truth.ids.tolist(), truth.positions):
            if frame.stamp - last_seen.get(ident, -np.inf) > 1.5 * scan_period:
                came_into_view[ident] = frame.stamp
            last_seen[ident] = frame.stamp
            if len(tracks.ids) and np.linalg.norm(tracks.positions - position, axis=1).min() \
                    <= pe.MATCH_RADIUS:
                continue
            counts["misses"] += 1
            counts["new_in_view"] += int(frame.stamp - came_into_view[ident] <= NEW_IN_VIEW)
            counts["far"] += int(np.linalg.norm(position - pose[:2]) > FAR)
        counted = pe.benchmark_counted(run.grid, pose, frame.positions, run.view)
        for position in published:
            gaps = np.linalg.norm(frame.positions - position, axis=1)
            if counted.any() and gaps[counted].min() <= pe.BENCHMARK_RADIUS:
                continue
            counts["false_positives"] += 1
            nearest = gaps.min() if len(gaps) else np.inf
            key = ("near_a_person_left_out" if nearest <= 0.3 else
                   "within_0.75" if nearest <= pe.BENCHMARK_RADIUS else "far_from_everyone")
            counts[key] += 1
    return counts


def main(paths: list[str]) -> None:
    """Print the sums over the runs at ``paths``."""
    total: dict[str, int] = {}
    for path in paths:
        for key, value in errors(path).items():
            total[key] = total.get(key, 0) + value
    print(f"misses {total['misses']}: within {NEW_IN_VIEW} s of coming into view "
          f"{total['new_in_view']}, beyond {FAR} m {total['far']}")
    print(f"benchmark false positives {total['false_positives']}: within 0.3 m of a person "
          f"it leaves out {total['near_a_person_left_out']}, 0.3-0.75 m from the nearest "
          f"{total['within_0.75']}, no person within 0.75 m {total['far_from_everyone']}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
