"""Launch fastslam_node with a parameter file.

ros2 launch fastslam_ros fastslam.launch.py
ros2 launch fastslam_ros fastslam.launch.py params_file:=my.yaml namespace:=robot1 \
        use_sim_time:=true odom_topic:=/wheel/odom landmarks_topic:=/detector/landmarks
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
                                                "fastslam.yaml"]),
            description="YAML parameter file of the node"),
        DeclareLaunchArgument("namespace", default_value="",
                              description="Namespace of the node and its relative topics"),
        DeclareLaunchArgument("use_sim_time", default_value="false",
                              description="Use /clock (bag replay, simulation)"),
        DeclareLaunchArgument("odom_topic", default_value="odom",
                              description="nav_msgs/Odometry input"),
        DeclareLaunchArgument("landmarks_topic", default_value="landmarks",
                              description="sensor_msgs/PointCloud2 landmark input"),
    ]
    node = Node(
        package="fastslam_ros",
        executable="fastslam_node",
        name="fastslam",
        namespace=LaunchConfiguration("namespace"),
        output="screen",
        parameters=[
            LaunchConfiguration("params_file"),
            {"use_sim_time": ParameterValue(LaunchConfiguration("use_sim_time"), value_type=bool)},
        ],
        remappings=[("odom", LaunchConfiguration("odom_topic")),
                    ("landmarks", LaunchConfiguration("landmarks_topic"))],
    )
    return LaunchDescription(arguments + [node])
