"""Calibrate a camera or a stereo pair with stereocal's calibrate_node.

Mono (the default) reads <camera>/image_raw and calls <camera>/set_camera_info on
commit; stereo (`stereo:=true`) reads <camera>/left/image_raw and
<camera>/right/image_raw and calls <camera>/left/set_camera_info and
<camera>/right/set_camera_info. Parameters come from config/calibrate_node.yaml;
the board is set there or here:

    ros2 launch launch/calibrate.launch.py camera:=/my_camera size:=8x6 square:=0.108
    ros2 launch launch/calibrate.launch.py stereo:=true camera:=/stereo slop:=0.01 \
        calibrate_node:=$PWD/target/release/calibrate_node

Then watch /<camera>/calibrate_node/status and call the services:

    ros2 service call /<camera>/calibrate_node/calibrate std_srvs/srv/Trigger
    ros2 service call /<camera>/calibrate_node/commit std_srvs/srv/Trigger

`calibrate_node` is the executable (by default found on PATH, e.g. after
`cargo install --path .`); stereocal is not an ament package, so the node is started
by executable rather than by package name.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PARAMS_FILE = os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "..", "config", "calibrate_node.yaml"
)


def calibrate_node(context):
    camera = LaunchConfiguration("camera").perform(context).rstrip("/")
    stereo = LaunchConfiguration("stereo").perform(context).lower() in ("true", "1")
    if stereo:
        remappings = [
            ("left/image", f"{camera}/left/image_raw"),
            ("right/image", f"{camera}/right/image_raw"),
            ("left/set_camera_info", f"{camera}/left/set_camera_info"),
            ("right/set_camera_info", f"{camera}/right/set_camera_info"),
        ]
    else:
        remappings = [
            ("image", f"{camera}/image_raw"),
            ("set_camera_info", f"{camera}/set_camera_info"),
        ]
    overrides = {"stereo": stereo}
    for name in ("size", "square", "slop"):
        value = LaunchConfiguration(name).perform(context)
        if value:
            overrides[name] = float(value) if name != "size" else value
    return [
        Node(
            executable=LaunchConfiguration("calibrate_node"),
            name="calibrate_node",
            namespace=camera or "/",
            parameters=[LaunchConfiguration("params_file"), overrides],
            remappings=remappings,
            output="screen",
        )
    ]


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "calibrate_node",
                default_value="calibrate_node",
                description="calibrate_node executable (a path, or a name on PATH)",
            ),
            DeclareLaunchArgument(
                "camera",
                default_value="/camera",
                description="namespace of the camera's (or the stereo pair's) topics",
            ),
            DeclareLaunchArgument(
                "stereo", default_value="false", description="calibrate a stereo pair"
            ),
            DeclareLaunchArgument(
                "size", default_value="", description="board size COLSxROWS (over the params file)"
            ),
            DeclareLaunchArgument(
                "square", default_value="", description="square side, metres (over the params file)"
            ),
            DeclareLaunchArgument(
                "slop", default_value="", description="stereo pairing slop, seconds (over the params file)"
            ),
            DeclareLaunchArgument(
                "params_file",
                default_value=PARAMS_FILE,
                description="ROS 2 params file for the node",
            ),
            OpaqueFunction(function=calibrate_node),
        ]
    )
