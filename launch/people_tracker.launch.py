"""Launch people_tracker_node with a parameter file.

ros2 launch fastslam_ros people_tracker.launch.py
ros2 launch fastslam_ros people_tracker.launch.py params_file:=my.yaml scan_topic:=/base_scan \
        map_topic:=/map odom_topic:=/odom use_sim_time:=true
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare


def generate_launch_description() -> LaunchDescription:
    """The node, its parameter file, and the arguments that select namespace, clock and topics."""
    arguments = [
        DeclareLaunchArgument(
            "params_file",
            default_value=PathJoinSubstitution([FindPackageShare("fastslam_ros"), "config",
                                                "people_tracker.yaml"]),
            description="YAML parameter file of the node"),
        DeclareLaunchArgument("namespace", default_value="",
                              description="Namespace of the node and its relative topics"),
        DeclareLaunchArgument("use_sim_time", default_value="false",
                              description="Use /clock (bag replay, simulation)"),
        DeclareLaunchArgument("scan_topic", default_value="scan",
                              description="sensor_msgs/LaserScan input"),
        DeclareLaunchArgument("odom_topic", default_value="odom",
                              description="nav_msgs/Odometry input"),
        DeclareLaunchArgument("map_topic", default_value="map",
                              description="nav_msgs/OccupancyGrid input (transient local)"),
        DeclareLaunchArgument("initialpose_topic", default_value="initialpose",
                              description="geometry_msgs/PoseWithCovarianceStamped input (RViz)"),
    ]
    node = Node(
        package="fastslam_ros",
        executable="people_tracker_node",
        name="people_tracker",
        namespace=LaunchConfiguration("namespace"),
        output="screen",
        parameters=[
            LaunchConfiguration("params_file"),
            {"use_sim_time": ParameterValue(LaunchConfiguration("use_sim_time"), value_type=bool)},
        ],
        remappings=[("scan", LaunchConfiguration("scan_topic")),
                    ("odom", LaunchConfiguration("odom_topic")),
                    ("map", LaunchConfiguration("map_topic")),
                    ("initialpose", LaunchConfiguration("initialpose_topic"))],
    )
    return LaunchDescription(arguments + [node])
