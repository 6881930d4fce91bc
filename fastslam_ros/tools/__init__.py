# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Command-line tools: simulator, bag replay and playback, evaluation, converters, benchmarks."""
