# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Simulated worlds: ``fastslam-sim`` (landmark worlds to bags), ``people_sim`` (people on a
known map), ``world`` (the one generative model) and ``synthetic`` (in-memory worlds for tests
and benchmarks)."""
