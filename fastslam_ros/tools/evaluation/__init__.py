# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Scoring against ground truth: ``fastslam-eval`` (``evaluate``; ``people_eval`` for the
people tracker), the metrics, the plots, and the noise fit (``calibrate``)."""
