"""Launch fastslam_node with a parameter file.

ros2 launch fastslam_ros fastslam.launch.py
ros2 launch fastslam_ros fastslam.launch.py params_file:=my.yaml namespace:=robot1 \
        use_sim_time:=true odom_topic:=/wheel/odom landmarks_topic:=/detector/landmarks
"""
from fastslam_ros.launch_common import node_launch_description


def generate_launch_description():
    """The node, its parameter file, and the arguments that select namespace, clock and topics."""
    return node_launch_description("fastslam_node", "fastslam", "fastslam.yaml", [
        ("odom", "nav_msgs/Odometry input"),
        ("landmarks", "sensor_msgs/PointCloud2 landmark input"),
    ])
