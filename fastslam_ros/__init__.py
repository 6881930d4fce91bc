"""FastSLAM landmark SLAM for ROS 2: the ROS-free core, the node and the tools."""
