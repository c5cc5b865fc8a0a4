"""Run a stereo pair of V4L2 cameras: one stereocal camera_node per side.

The nodes run in <camera>/left and <camera>/right (default /stereo), named `left` and
`right` (their calibrations are ${ROS_HOME}/camera_info/left.yaml and right.yaml unless
the params file says otherwise), publish <camera>/<side>/image_raw and camera_info, and
serve <camera>/<side>/set_camera_info, as a stereo calibrate_node expects. The right
node compares its stamps with the left camera's: `stereo_sync` in
<camera>/right/camera_node/status gives the last, median and largest stamp difference
of the pair over the last 100 frames, so a user sees whether the cameras are in step
(free-running cameras drift up to half a frame interval apart; a hardware-triggered
pair stays near zero).

    ros2 launch launch/stereo_camera.launch.py left_device:=/dev/video0 \
        right_device:=/dev/video2 pixel_format:=MJPEG image_width:=1280 image_height:=720
    ros2 topic echo /stereo/right/camera_node/status

`camera_node` is the executable (by default found on PATH, e.g. after
`cargo install --path .`); stereocal is not an ament package, so the nodes are started
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

#: Launch arguments that override the params file for both cameras when given.
OVERRIDES = {"pixel_format": str, "image_width": int, "image_height": int, "framerate": float}


def camera_nodes(context):
    camera = LaunchConfiguration("camera").perform(context).rstrip("/")
    shared = {}
    for name, kind in OVERRIDES.items():
        value = LaunchConfiguration(name).perform(context)
        if value:
            shared[name] = kind(value)
    nodes = []
    for side, partner in (("left", ""), ("right", f"{camera}/left/camera_info")):
        own = {
            **shared,
            "video_device": LaunchConfiguration(f"{side}_device").perform(context),
            "camera_name": side,
            "frame_id": f"{side}_camera_optical_frame",
            "stereo_partner": partner,
        }
        nodes.append(
            Node(
                executable=LaunchConfiguration("camera_node"),
                name="camera_node",
                namespace=f"{camera}/{side}",
                parameters=[LaunchConfiguration("params_file"), own],
                output="screen",
            )
        )
    return nodes


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
                default_value="/stereo",
                description="namespace of the pair: <camera>/left and <camera>/right",
            ),
            DeclareLaunchArgument(
                "left_device", default_value="/dev/video0", description="the left camera's device"
            ),
            DeclareLaunchArgument(
                "right_device", default_value="/dev/video2", description="the right camera's device"
            ),
            DeclareLaunchArgument(
                "pixel_format", default_value="", description="YUYV, MJPEG or GREY (both cameras)"
            ),
            DeclareLaunchArgument(
                "image_width", default_value="", description="pixels (both cameras)"
            ),
            DeclareLaunchArgument(
                "image_height", default_value="", description="pixels (both cameras)"
            ),
            DeclareLaunchArgument(
                "framerate", default_value="", description="frames per second (both cameras)"
            ),
            DeclareLaunchArgument(
                "params_file",
                default_value=PARAMS_FILE,
                description="ROS 2 params file for both nodes",
            ),
            OpaqueFunction(function=camera_nodes),
        ]
    )
