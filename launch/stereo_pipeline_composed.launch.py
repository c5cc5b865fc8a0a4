"""A stereo camera's whole pipeline in one process: rectify both images, match them,
and turn the disparity into a point cloud.

`stereocal node compose` runs the nodes that config/stereo_pipeline_composition.yaml
lists (/stereo/left/rectify_node and /stereo/right/rectify_node reading
/stereo/<side>/image_raw and /stereo/<side>/camera_info; /stereo/disparity_node
publishing /stereo/disparity; /stereo/point_cloud_node publishing /stereo/points2) with
the parameters of config/stereo_rectify.yaml and config/stereo_depth.yaml, like a
component container: one process, one SIGINT to stop them all.

    ros2 launch launch/stereo_pipeline_composed.launch.py
    ros2 launch launch/stereo_pipeline_composed.launch.py \
        stereocal:=$PWD/target/release/stereocal depth_params_file:=$PWD/my_depth.yaml

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
                default_value=os.path.join(CONFIG, "stereo_pipeline_composition.yaml"),
                description="composition file: the nodes the process runs",
            ),
            DeclareLaunchArgument(
                "rectify_params_file",
                default_value=os.path.join(CONFIG, "stereo_rectify.yaml"),
                description="ROS 2 params file of the rectify nodes",
            ),
            DeclareLaunchArgument(
                "depth_params_file",
                default_value=os.path.join(CONFIG, "stereo_depth.yaml"),
                description="ROS 2 params file of disparity_node and point_cloud_node",
            ),
            # No node name or namespace here: each node of the composition has its own.
            Node(
                executable=LaunchConfiguration("stereocal"),
                arguments=["node", "compose", LaunchConfiguration("composition")],
                parameters=[
                    LaunchConfiguration("rectify_params_file"),
                    LaunchConfiguration("depth_params_file"),
                ],
                output="screen",
            ),
        ]
    )
