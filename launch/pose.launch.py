"""Estimate a calibration target's pose with stereocal's pose_node.

Reads <camera>/image_raw (or <camera>/image_rect with `rectified:=true`) and
<camera>/camera_info, and publishes <camera>/target_pose,
<camera>/target_pose_with_covariance and /tf (camera frame -> target_frame).
Parameters come from config/pose_node.yaml; the board is set there or here:

    ros2 launch launch/pose.launch.py camera:=/my_camera size:=8x6 square:=0.108
    ros2 launch launch/pose.launch.py camera:=/stereo/left rectified:=true \
        pose_node:=$PWD/target/release/pose_node

Then watch /<camera>/pose_node/status and /<camera>/pose_node/annotated_image.

`pose_node` is the executable (by default found on PATH, e.g. after
`cargo install --path .`); stereocal is not an ament package, so the node is started
by executable rather than by package name.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PARAMS_FILE = os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "..", "config", "pose_node.yaml"
)


def pose_node(context):
    camera = LaunchConfiguration("camera").perform(context).rstrip("/")
    rectified = LaunchConfiguration("rectified").perform(context).lower() in ("true", "1")
    image = "image_rect" if rectified else "image_raw"
    overrides = {"image_is_rectified": rectified}
    for name in ("size", "square", "target_frame"):
        value = LaunchConfiguration(name).perform(context)
        if value:
            overrides[name] = float(value) if name == "square" else value
    return [
        Node(
            executable=LaunchConfiguration("pose_node"),
            name="pose_node",
            namespace=camera or "/",
            parameters=[LaunchConfiguration("params_file"), overrides],
            remappings=[
                ("image", f"{camera}/{image}"),
                ("camera_info", f"{camera}/camera_info"),
            ],
            output="screen",
        )
    ]


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "pose_node",
                default_value="pose_node",
                description="pose_node executable (a path, or a name on PATH)",
            ),
            DeclareLaunchArgument(
                "camera",
                default_value="/camera",
                description="namespace of the camera's topics",
            ),
            DeclareLaunchArgument(
                "rectified",
                default_value="false",
                description="read image_rect and see it through camera_info's P",
            ),
            DeclareLaunchArgument(
                "size", default_value="", description="board size COLSxROWS (over the params file)"
            ),
            DeclareLaunchArgument(
                "square", default_value="", description="square side, metres (over the params file)"
            ),
            DeclareLaunchArgument(
                "target_frame", default_value="", description="TF frame of the target (over the params file)"
            ),
            DeclareLaunchArgument(
                "params_file",
                default_value=PARAMS_FILE,
                description="ROS 2 params file for the node",
            ),
            OpaqueFunction(function=pose_node),
        ]
    )
