# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Measurements that print figures, never asserts: throughput (``bench``), the datasets
(``benchmark``), localization on saved maps (``localization_bench``), hours of data
(``soak``) and a live DDS load (``live_load``)."""
