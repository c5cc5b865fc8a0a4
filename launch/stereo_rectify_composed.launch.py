"""Rectify a stereo camera with both rectify nodes in one process.

`stereocal node compose` runs the nodes that config/stereo_rectify_composition.yaml
lists (/stereo/left/rectify_node and /stereo/right/rectify_node, reading
/stereo/<side>/image_raw and /stereo/<side>/camera_info, publishing
/stereo/<side>/image_rect) with the parameters of config/stereo_rectify.yaml, like a
component container: one process, one SIGINT to stop both.

    ros2 launch launch/stereo_rectify_composed.launch.py
    ros2 launch launch/stereo_rectify_composed.launch.py \
        stereocal:=$PWD/target/release/stereocal composition:=$PWD/my_composition.yaml

`stereocal` is the executable (by default found on PATH, e.g. after
`cargo install --path .`).
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

CONFIG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config")


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "stereocal",
                default_value="stereocal",
                description="stereocal executable (a path, or a name on PATH)",
            ),
            DeclareLaunchArgument(
                "composition",
                default_value=os.path.join(CONFIG, "stereo_rectify_composition.yaml"),
                description="composition file: the nodes the process runs",
            ),
            DeclareLaunchArgument(
                "params_file",
                default_value=os.path.join(CONFIG, "stereo_rectify.yaml"),
                description="ROS 2 params file for every node of the composition",
            ),
            # No node name or namespace here: each node of the composition has its own.
            Node(
                executable=LaunchConfiguration("stereocal"),
                arguments=["node", "compose", LaunchConfiguration("composition")],
                parameters=[LaunchConfiguration("params_file")],
                output="screen",
            ),
        ]
    )
