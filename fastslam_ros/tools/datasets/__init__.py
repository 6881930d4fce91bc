# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Real datasets to schema bags: ``fastslam-convert`` (``convert``) and one converter per
dataset family (``converters``)."""
