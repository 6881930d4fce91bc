# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""Bags: the schema (``bag_schema``), CDR reading (``cdr``), the in-process replay through a
node (``replay``), DDS playback (``play``) and fault injection (``poison``)."""
