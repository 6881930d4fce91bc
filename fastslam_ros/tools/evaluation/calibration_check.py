# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""A calibration that never hurts: ``fastslam-calibrate`` checks its fit on data it did not
see before it writes it.

Each bag is split in time: the noise is fitted on the first part only, and the last part (the
held-out part) is replayed through the node twice, with the parameters the user started from
and with the fitted ones, seeds ``VALIDATION_SEEDS``. The fit is written only when its mean
aligned ATE over the held-out parts is no worse than the starting parameters' (within
``TOLERANCE``): a fit that rejects more observations, or trusts a sensor more than the
filter's map can support, shows as a worse estimate there, whatever its residuals say.
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
held out."""
VALIDATION_SEEDS = (1, 2, 3)
"""Filter seeds of the held-out replays (the ATE of one seed moves with the draws)."""
TOLERANCE = 1.02
"""The fit is kept when its held-out ATE is at most this factor of the starting one."""


@dataclasses.dataclass
class Verdict:
    """The held-out comparison: mean aligned ATE (m) with the starting and the fitted
    parameters, and whether the fit may be written."""

    start_ate: float
    fitted_ate: float

    @property
    def keeps_fit(self) -> bool:
        """The fit is no worse than the start on the held-out data."""
        return self.fitted_ate <= TOLERANCE * self.start_ate


def _cut_poses(series: PoseSeries | None, keep: Callable[[np.ndarray], np.ndarray]
               ) -> PoseSeries | None:
    if series is None:
        return None
    mask = keep(series.stamps)
    return dataclasses.replace(series, stamps=series.stamps[mask], poses=series.poses[mask])


def split_bag(bag: SchemaBag, fraction: float = FIT_FRACTION) -> tuple[SchemaBag, SchemaBag]:
    """(first part, held-out part) of ``bag``, cut at ``fraction`` of its odometry's span."""
    stamps = bag.odometry.stamps
    cut = stamps[0] + fraction * (stamps[-1] - stamps[0])
    parts = []
    for keep in (lambda t: t < cut, lambda t: t >= cut):
        chosen = np.flatnonzero(keep(bag.scans.stamps))
        scans = LandmarkScans(bag.scans.stamps[chosen], [bag.scans.points[i] for i in chosen],
                              [bag.scans.ids[i] for i in chosen], bag.scans.frame_id)
        parts.append(SchemaBag(_cut_poses(bag.odometry, keep), scans,
                               _cut_poses(bag.ground_truth, keep), bag.landmarks_truth))
    return parts[0], parts[1]


def held_out_ate(bags: list[SchemaBag], params: dict[str, Any]) -> float:
    """Mean aligned ATE (m) of the estimate at the time over ``bags`` and VALIDATION_SEEDS,
    each bag replayed through the node with ``params``."""
    from fastslam_ros.tools.bags.bag_schema import write_schema_bag
    from fastslam_ros.tools.bags.replay import replay_bag
    from fastslam_ros.tools.evaluation.evaluate import evaluate_run, load_run

    errors = []
    with tempfile.TemporaryDirectory(prefix="fastslam_calibration_") as folder:
        for index, bag in enumerate(bags):
            path = write_schema_bag(Path(folder) / f"held_out_{index}", bag)
            for seed in VALIDATION_SEEDS:
                run = Path(folder) / f"run_{index}_{seed}"
                replay_bag(path, dict(params, seed=seed), out_path=run)
                metrics = evaluate_run(load_run(run)).metrics
                errors.append(metrics["estimate"]["aligned"]["rmse"])
    return float(np.mean(errors))


def check_fit(bags: list[SchemaBag], start: dict[str, Any],
              fit: Callable[[list[SchemaBag]], dict[str, Any]]) -> Verdict:
    """Fit on the first part of every bag (``fit``: bags -> parameter values), replay the
    held-out parts with ``start`` and with the fit, and compare."""
    firsts, held_out = zip(*(split_bag(bag) for bag in bags))
    fitted = fit(list(firsts))
    return Verdict(held_out_ate(list(held_out), start), held_out_ate(list(held_out), fitted))
