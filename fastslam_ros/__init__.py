# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""FastSLAM landmark SLAM for ROS 2: the ROS-free core, the node and the tools."""
