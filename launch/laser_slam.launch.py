"""Launch landmark_extractor_node and fastslam_node together: SLAM from a 2-D laser.

ros2 launch fastslam_ros laser_slam.launch.py
ros2 launch fastslam_ros laser_slam.launch.py scan_topic:=/base_scan odom_topic:=/odom \
        extractor_params_file:=my_extractor.yaml params_file:=my_slam.yaml use_sim_time:=true

The extractor turns scans into landmark clouds on ``landmarks``, which the SLAM node reads in
the same namespace (set the SLAM node's sensor_frame and sensor_x/y/yaw to the laser's).
"""
from fastslam_ros.launch_common import PACKAGE


def generate_launch_description():
    """Both nodes, one parameter file each, the namespace, the clock and the input topics."""
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument
    from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
    from launch_ros.actions import Node
    from launch_ros.parameter_descriptions import ParameterValue
    from launch_ros.substitutions import FindPackageShare

    def config(name):
        return PathJoinSubstitution([FindPackageShare(PACKAGE), "config", name])

    arguments = [
        DeclareLaunchArgument("extractor_params_file", default_value=config(
            "landmark_extractor.yaml"), description="YAML parameter file of the extractor"),
        DeclareLaunchArgument("params_file", default_value=config("fastslam.yaml"),
                              description="YAML parameter file of the SLAM node"),
        DeclareLaunchArgument("namespace", default_value="",
                              description="Namespace of the nodes and their relative topics"),
        DeclareLaunchArgument("use_sim_time", default_value="false",
                              description="Use /clock (bag replay, simulation)"),
        DeclareLaunchArgument("scan_topic", default_value="scan",
                              description="sensor_msgs/LaserScan input of the extractor"),
        DeclareLaunchArgument("odom_topic", default_value="odom",
                              description="nav_msgs/Odometry input of the SLAM node and of "
                                          "the extractor (deskew_scans, static_window)"),
    ]
    clock = {"use_sim_time": ParameterValue(LaunchConfiguration("use_sim_time"), value_type=bool)}
    nodes = [
        Node(package=PACKAGE, executable=executable, name=name,
             namespace=LaunchConfiguration("namespace"), output="screen",
             parameters=[LaunchConfiguration(params_file), clock],
             remappings=[(topic, LaunchConfiguration(f"{topic}_topic")) for topic in topics])
        for executable, name, params_file, topics in (
            ("landmark_extractor_node", "landmark_extractor", "extractor_params_file",
             ("scan", "odom")),
            ("fastslam_node", "fastslam", "params_file", ("odom",)))
    ]
    return LaunchDescription(arguments + nodes)
