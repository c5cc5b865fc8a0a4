"""Stereo depth with stereocal's disparity_node and point_cloud_node.

Reads a rectified pair, <camera>/left/image_rect and <camera>/right/image_rect with
<camera>/left/camera_info and <camera>/right/camera_info (for example what
launch/stereo_rectify.launch.py publishes), and publishes <camera>/disparity
(stereo_msgs/DisparityImage) and <camera>/points2 (sensor_msgs/PointCloud2, coloured
from <camera>/left/image_rect). Parameters come from config/stereo_depth.yaml:

    ros2 launch launch/stereo_depth.launch.py camera:=/my_stereo disparity_range:=96
    ros2 launch launch/stereo_depth.launch.py \\
        disparity_node:=$PWD/target/release/disparity_node \\
        point_cloud_node:=$PWD/target/release/point_cloud_node

`disparity_node` and `point_cloud_node` are executables (by default found on PATH, e.g.
after `cargo install --path .`); stereocal is not an ament package, so the nodes are
started by executable rather than by package name.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PARAMS_FILE = os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "..", "config", "stereo_depth.yaml"
)


def depth_nodes(context):
    camera = LaunchConfiguration("camera").perform(context).rstrip("/")
    overrides = {}
    disparity_range = LaunchConfiguration("disparity_range").perform(context)
    if disparity_range:
        overrides["disparity_range"] = int(disparity_range)
    topics = [
        (f"{side}/{name}", f"{camera}/{side}/{name}")
        for side in ("left", "right")
        for name in ("image_rect", "camera_info")
    ]
    return [
        Node(
            executable=LaunchConfiguration("disparity_node"),
            name="disparity_node",
            namespace=camera or "/",
            parameters=[LaunchConfiguration("params_file"), overrides],
            remappings=[*topics, ("disparity", f"{camera}/disparity")],
            output="screen",
        ),
        Node(
            executable=LaunchConfiguration("point_cloud_node"),
            name="point_cloud_node",
            namespace=camera or "/",
            parameters=[LaunchConfiguration("params_file")],
            remappings=[
                ("left/image_rect_color", f"{camera}/left/image_rect"),
                ("left/camera_info", f"{camera}/left/camera_info"),
                ("right/camera_info", f"{camera}/right/camera_info"),
                ("disparity", f"{camera}/disparity"),
                ("points2", f"{camera}/points2"),
            ],
            output="screen",
        ),
    ]


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "disparity_node",
                default_value="disparity_node",
                description="disparity_node executable (a path, or a name on PATH)",
            ),
            DeclareLaunchArgument(
                "point_cloud_node",
                default_value="point_cloud_node",
                description="point_cloud_node executable (a path, or a name on PATH)",
            ),
            DeclareLaunchArgument(
                "camera",
                default_value="/stereo",
                description="namespace of the pair's topics (left/..., right/...)",
            ),
            DeclareLaunchArgument(
                "disparity_range",
                default_value="",
                description="disparities searched (over the params file)",
            ),
            DeclareLaunchArgument(
                "params_file",
                default_value=PARAMS_FILE,
                description="ROS 2 params file for both nodes",
            ),
            OpaqueFunction(function=depth_nodes),
        ]
    )
