"""Run a V4L2 camera with stereocal's camera_node.

Publishes <camera>/image_raw (or <camera>/image_raw/compressed for MJPEG passed through),
<camera>/camera_info, and serves <camera>/set_camera_info, which calibrate_node's
~/commit calls. Parameters come from config/camera_node.yaml; the device, format and
size are set there or here:

    ros2 launch launch/camera.launch.py video_device:=/dev/video0 pixel_format:=MJPEG \
        image_width:=1920 image_height:=1080 framerate:=30.0
    ros2 launch launch/camera.launch.py video_device:=test_pattern \
        camera_node:=$PWD/target/release/camera_node

Then watch /<camera>/camera_node/status.

`camera_node` is the executable (by default found on PATH, e.g. after
`cargo install --path .`); stereocal is not an ament package, so the node is started
by executable rather than by package name.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PARAMS_FILE = os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "..", "config", "camera_node.yaml"
)

#: Launch arguments that override the params file when given, with their types.
OVERRIDES = {
    "video_device": str,
    "pixel_format": str,
    "image_width": int,
    "image_height": int,
    "framerate": float,
    "camera_name": str,
    "frame_id": str,
    "camera_info_url": str,
}


def camera_node(context):
    camera = LaunchConfiguration("camera").perform(context).rstrip("/")
    overrides = {}
    for name, kind in OVERRIDES.items():
        value = LaunchConfiguration(name).perform(context)
        if value:
            overrides[name] = kind(value)
    return [
        Node(
            executable=LaunchConfiguration("camera_node"),
            name="camera_node",
            namespace=camera or "/",
            parameters=[LaunchConfiguration("params_file"), overrides],
            output="screen",
        )
    ]


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "camera_node",
                default_value="camera_node",
                description="camera_node executable (a path, or a name on PATH)",
            ),
            DeclareLaunchArgument(
                "camera",
                default_value="/camera",
                description="namespace of the camera's topics and set_camera_info",
            ),
            DeclareLaunchArgument(
                "video_device", default_value="",
                description="V4L2 device or test_pattern (over the params file)",
            ),
            DeclareLaunchArgument(
                "pixel_format", default_value="",
                description="YUYV, MJPEG or GREY (over the params file)",
            ),
            DeclareLaunchArgument(
                "image_width", default_value="", description="pixels (over the params file)"
            ),
            DeclareLaunchArgument(
                "image_height", default_value="", description="pixels (over the params file)"
            ),
            DeclareLaunchArgument(
                "framerate", default_value="", description="frames per second (over the params file)"
            ),
            DeclareLaunchArgument(
                "camera_name", default_value="camera",
                description="the camera's name: its calibration file is ${NAME}.yaml",
            ),
            DeclareLaunchArgument(
                "frame_id", default_value="camera_optical_frame",
                description="the camera's optical frame",
            ),
            DeclareLaunchArgument(
                "camera_info_url", default_value="",
                description="where the calibration is kept (over the params file)",
            ),
            DeclareLaunchArgument(
                "params_file",
                default_value=PARAMS_FILE,
                description="ROS 2 params file for the node",
            ),
            OpaqueFunction(function=camera_node),
        ]
    )
