"""Rectify a stereo camera: one stereocal rectify_node per side.

The nodes run in the `left` and `right` namespaces with parameters from
config/stereo_rectify.yaml, read /stereo/<side>/image_raw and
/stereo/<side>/camera_info, and publish /stereo/<side>/image_rect.

    ros2 launch launch/stereo_rectify.launch.py
    ros2 launch launch/stereo_rectify.launch.py \
        rectify_node:=$PWD/target/release/rectify_node camera:=/my_stereo

`rectify_node` is the executable (by default found on PATH, e.g. after
`cargo install --path .`); stereocal is not an ament package, so the nodes are
started by executable rather than by package name.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PARAMS_FILE = os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "..", "config", "stereo_rectify.yaml"
)


def rectify_node(side):
    camera = LaunchConfiguration("camera")
    return Node(
        executable=LaunchConfiguration("rectify_node"),
        name="rectify_node",
        namespace=side,
        parameters=[LaunchConfiguration("params_file")],
        remappings=[
            ("image", [camera, f"/{side}/image_raw"]),
            ("camera_info", [camera, f"/{side}/camera_info"]),
            ("image_rect", [camera, f"/{side}/image_rect"]),
        ],
        output="screen",
    )


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "rectify_node",
                default_value="rectify_node",
                description="rectify_node executable (a path, or a name on PATH)",
            ),
            DeclareLaunchArgument(
                "camera",
                default_value="/stereo",
                description="namespace of the stereo camera's topics",
            ),
            DeclareLaunchArgument(
                "params_file",
                default_value=PARAMS_FILE,
                description="ROS 2 params file for both nodes",
            ),
            rectify_node("left"),
            rectify_node("right"),
        ]
    )
