# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""The vectorized filter against a plain per-particle reference, step by step, same draws."""
from __future__ import annotations

import numpy as np
import pytest

from fastslam_ros.core import FastSLAM, FastSLAMConfig
from fastslam_ros.core import fastslam as fastslam_module
from fastslam_ros.tools.simulation.synthetic import make_world
from reference_fastslam import ReferenceFastSLAM

CASES = [
    # (algorithm, association, flush distance)
    ("fastslam2", "ml", 0.3),  # odometry flushed between readings: the 2.0 prior
    ("fastslam1", "known", 5.0), ("fastslam1", "ml", 0.3),
    ("fastslam1", "monte_carlo", 5.0), ("fastslam1", "two_gate", 5.0),
    ("fastslam2", "known", 5.0), ("fastslam2", "ml", 5.0),
    ("fastslam2", "monte_carlo", 5.0), ("fastslam2", "two_gate", 5.0),
]
MAX_PRIOR_HEADING_SIGMA = 0.06
"""Low, so that the runs also sample the FastSLAM 2.0 prior when it grows too wide."""
ROBUST_CASES = [("fastslam1", "known", 5.0), ("fastslam2", "known", 5.0),
                ("fastslam2", "ml", 0.3), ("fastslam2", "ml", 5.0), ("fastslam1", "ml", 5.0)]
"""Range noise growing with the range, the outlier-robust likelihood, random-walk motion noise."""
ROBUST = dict(sigma_range_per_meter=0.03, outlier_probability=0.3, new_landmark_likelihood=1e-3,
              rotation_variance_per_radian=0.01, rotation_variance_per_meter=0.004,
              translation_variance_per_meter=0.002, translation_variance_per_radian=0.001)


def small_config(algorithm: str, association: str, flush: float,
                 extra: dict | None = None) -> FastSLAMConfig:
    return FastSLAMConfig(
        num_particles=12, algorithm=algorithm, association=association,
        new_landmark_likelihood=0.05, association_gate=6.0, new_landmark_gate=16.0,
        alpha1=0.02, alpha2=0.002, alpha3=0.02, alpha4=0.005,
        sigma_range=0.15, sigma_bearing=0.03,
        sensor_x=0.3, sensor_y=-0.1, sensor_yaw=0.05,
        max_range=9.0, field_of_view=np.deg2rad(200.0),
        logodds_observed=0.8, logodds_missed=-0.9, logodds_remove=-0.5,
        resample_threshold=0.7, cell_size=4.0, persistent_landmarks=True,
        max_pending_translation=flush).replace(**(extra or {}))


def sorted_map(means, covs, logodds, labels):
    order = np.lexsort((means[:, 1], means[:, 0]))
    return means[order], covs[order], logodds[order], labels[order]


@pytest.mark.parametrize("algorithm,association,flush,extra",
                         [case + (None,) for case in CASES]
                         + [case + (ROBUST,) for case in ROBUST_CASES]
                         + [("fastslam2", "monte_carlo", 5.0, ROBUST),
                            ("fastslam2", "ml", 0.3, {"persistent_landmarks": False}),
                            ("fastslam2", "ml", 0.3, {"persistent_landmarks": False,
                                                      "keep_confirmed_landmarks": False})])
def test_vectorized_filter_matches_reference(monkeypatch, algorithm, association, flush, extra,
                                             backend):
    world = make_world(seed=5, num_landmarks=7, extent=14.0, num_steps=40,
                       max_range=8.0, sigma_range=0.15, sigma_bearing=0.03,
                       detection_probability=0.7, clutter_per_step=0.8, laps=0.6)
    config = small_config(algorithm, association, flush, {**(extra or {}), "backend": backend})
    start = world.steps[0].truth
    monkeypatch.setattr(fastslam_module, "MAX_PRIOR_HEADING_SIGMA", MAX_PRIOR_HEADING_SIGMA)
    fast = FastSLAM(config, rng=np.random.default_rng(11), initial_pose=start)
    assert fast.backend == backend
    slow = ReferenceFastSLAM(config, np.random.default_rng(11), start, MAX_PRIOR_HEADING_SIGMA)
    previous = world.steps[0].odometry
    created = resampled = 0
    for k, step in enumerate(world.steps[1:]):
        # Several odometry messages per step exercise the accumulation of increments (and,
        # with a short flush distance, motion applied between readings).
        points = [previous + (step.odometry - previous) * f for f in (0.0, 0.3, 0.7, 1.0)]
        for a, b in zip(points[:-1], points[1:]):
            fast.predict(a, b)
            slow.predict(a, b)
        previous = step.odometry
        ids = step.ids.copy()
        if association == "known":
            keep = ids >= 0
            ranges, bearings, ids = step.ranges[keep], step.bearings[keep], ids[keep]
        else:
            ranges, bearings = step.ranges, step.bearings
        report = fast.update(ranges, bearings, ids, stamp=float(k))
        slow.update(ranges, bearings, ids)
        created += int(report.is_new.sum())
        resampled += report.resampled
        np.testing.assert_allclose(fast.poses, np.array(slow.poses), atol=1e-9, rtol=0)
        np.testing.assert_allclose(fast.log_weights, np.array(slow.log_w), atol=1e-9, rtol=0)
        for m in range(config.num_particles):
            mean, cov, logodds, label, _ = fast.particle_map(m)
            ref = slow.maps[m]
            assert len(mean) == len(ref), f"step {k} particle {m}: map sizes differ"
            if not ref:
                continue
            got = sorted_map(mean, cov, logodds, label)
            want = sorted_map(np.array([lm["mean"] for lm in ref]),
                              np.array([[lm["cov"][0, 0], lm["cov"][0, 1], lm["cov"][1, 1]]
                                        for lm in ref]),
                              np.array([lm["logodds"] for lm in ref]),
                              np.array([lm["label"] for lm in ref]))
            for g, w in zip(got, want):
                np.testing.assert_allclose(g, w, atol=1e-9, rtol=0)
    # The run must have exercised what it claims to test: creation, elimination, resampling,
    # landmarks a rejected observation explained.
    assert created > 0 and resampled > 0 and slow.removed > 0
    if config.persistent_landmarks:
        assert slow.explained > 0 or (association == "known" and not extra)
    else:
        assert slow.explained == 0
    assert slow.outliers > 0 or "outlier_probability" not in (extra or {})
