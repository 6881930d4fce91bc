# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A calibration that never hurts: ``fastslam-calibrate`` checks its fit on whole runs before it
writes it.

Each bag is split in time and the noise is fitted again on the first part only; then every bag
is replayed whole through the node with the parameters the user started from and with that
fit, seeds ``VALIDATION_SEEDS``, so the second part is data the fit never saw and the first
part holds the start of the run, where the map is built. The fit is written only when both its
mean and its worst aligned ATE over the replays are no worse than the starting parameters'
(within ``TOLERANCE``): a fit that rejects more observations, or trusts a sensor more than the
filter's associations can support, shows as a worse estimate there, whatever its residuals say
(docs/calibration.md: the second half replayed alone can favour a fit that whole runs reject).
"""
from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path
from typing import Any, Callable

import numpy as np

from fastslam_ros.tools.bags.bag_schema import LandmarkScans, PoseSeries, SchemaBag

FIT_FRACTION = 0.5
"""Share of each bag's time (from its first odometry stamp) the check fits on; the rest is
data the fit never saw."""
VALIDATION_SEEDS = (1, 2, 3, 4, 5)
"""Filter seeds of the replays (the ATE of one seed moves with the draws)."""
TOLERANCE = 1.02
"""The fit is kept when its mean and worst ATE are at most this factor of the starting ones."""


@dataclasses.dataclass
class Verdict:
    """The comparison: aligned ATE (m) of every replay (bag x seed) with the starting and the
    fitted parameters, and whether the fit may be written."""

    start_ates: np.ndarray
    fitted_ates: np.ndarray

    @staticmethod
    def summary(ates: np.ndarray) -> str:
        """'mean / worst' of a set of ATEs (m)."""
        return f"{float(np.mean(ates)):.4g} / {float(np.max(ates)):.4g}"

    @property
    def keeps_fit(self) -> bool:
        """The fit is no worse than the start on the mean and on the worst replay."""
        return bool(np.mean(self.fitted_ates) <= TOLERANCE * np.mean(self.start_ates)
                    and np.max(self.fitted_ates) <= TOLERANCE * np.max(self.start_ates))


def _cut_poses(series: PoseSeries | None, keep: Callable[[np.ndarray], np.ndarray]
               ) -> PoseSeries | None:
    if series is None:
        return None
    mask = keep(series.stamps)
    return dataclasses.replace(series, stamps=series.stamps[mask], poses=series.poses[mask])


def first_part(bag: SchemaBag, fraction: float = FIT_FRACTION) -> SchemaBag:
    """The messages of ``bag`` before ``fraction`` of its odometry's span (what the check fits
    on; the rest is data the fit never saw)."""
    stamps = bag.odometry.stamps
    cut = stamps[0] + fraction * (stamps[-1] - stamps[0])

    def keep(t: np.ndarray) -> np.ndarray:
        return t < cut
    chosen = np.flatnonzero(keep(bag.scans.stamps))
    scans = LandmarkScans(bag.scans.stamps[chosen], [bag.scans.points[i] for i in chosen],
                          [bag.scans.ids[i] for i in chosen], bag.scans.frame_id)
    return SchemaBag(_cut_poses(bag.odometry, keep), scans, _cut_poses(bag.ground_truth, keep),
                     bag.landmarks_truth)


def replay_ates(paths: list[str | Path], params: dict[str, Any]) -> np.ndarray:
    """Aligned ATE (m) of the estimate at the time of each bag and VALIDATION_SEED (bag-major),
    each bag (read, never written) replayed through the node with ``params`` into a temporary
    folder."""
    from fastslam_ros.tools.bags.replay import replay_bag
    from fastslam_ros.tools.evaluation.evaluate import evaluate_run, load_run

    errors = []
    with tempfile.TemporaryDirectory(prefix="fastslam_calibration_") as folder:
        for index, path in enumerate(paths):
            for seed in VALIDATION_SEEDS:
                run = Path(folder) / f"run_{index}_{seed}"
                replay_bag(path, dict(params, seed=seed), out_path=run)
                metrics = evaluate_run(load_run(run)).metrics
                errors.append(metrics["estimate"]["aligned"]["rmse"])
    return np.array(errors)


def check_fit(bags: list[SchemaBag], paths: list[str | Path], start: dict[str, Any],
              fit: Callable[[list[SchemaBag]], dict[str, Any]]) -> Verdict:
    """Fit on the first part of every bag (``fit``: bags -> parameter values), replay the
    whole bags (``paths``, where ``bags`` were read from) with ``start`` and with the fit,
    and compare."""
    fitted = fit([first_part(bag) for bag in bags])
    return Verdict(replay_ates(paths, start), replay_ates(paths, fitted))
