"""Launch people_tracker_node with a parameter file.

ros2 launch fastslam_ros people_tracker.launch.py
ros2 launch fastslam_ros people_tracker.launch.py params_file:=my.yaml scan_topic:=/base_scan \
        map_topic:=/map odom_topic:=/odom use_sim_time:=true
"""
from fastslam_ros.launch_common import node_launch_description


def generate_launch_description():
    """The node, its parameter file, and the arguments that select namespace, clock and topics."""
    return node_launch_description("people_tracker_node", "people_tracker",
                                   "people_tracker.yaml", [
                                       ("scan", "sensor_msgs/LaserScan input"),
                                       ("odom", "nav_msgs/Odometry input"),
                                       ("map", "nav_msgs/OccupancyGrid input (transient local)"),
                                       ("initialpose", "geometry_msgs/PoseWithCovarianceStamped "
                                                       "input (RViz)"),
                                   ])
