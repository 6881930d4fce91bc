# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""What the nodes need around the filters, ROS-free: the time alignment of odometry and
readings, the input gates on stamps and odometry (``timing``), and the check of the sensor's
stated reach against the observations (``sensor_reach``)."""
