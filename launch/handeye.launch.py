"""Run a hand-eye calibration session with stereocal's handeye_node, headless.

Eye-in-hand (the camera rides on the tool) or eye-to-hand (the camera stands still):

    ros2 launch launch/handeye.launch.py setup:=eye_in_hand camera:=/wrist_camera \
        base_frame:=base_link tool_frame:=tool0 size:=8x6 square:=0.03
    ros2 launch launch/handeye.launch.py setup:=eye_to_hand camera:=/scene_camera \
        robot_source:=topic robot_pose:=/robot/tool_pose

The node reads <camera>/image_raw and <camera>/camera_info (or <camera>/target_pose
from a pose_node with `target_source:=pose`) and the robot's pose from /tf (or from
`robot_pose` with `robot_source:=topic`). Move the robot, let it stand still, then

    ros2 service call /handeye_node/take_sample std_srvs/srv/Trigger
    ros2 service call /handeye_node/compute std_srvs/srv/Trigger
    ros2 service call /handeye_node/save std_srvs/srv/Trigger

and watch /handeye_node/status. The result goes to /tf_static. Parameters come from
config/handeye_node.yaml.

`handeye_node` is the executable (by default found on PATH, e.g. after
`cargo install --path .`); stereocal is not an ament package, so the node is started
by executable rather than by package name.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PARAMS_FILE = os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "..", "config", "handeye_node.yaml"
)

#: Launch arguments passed on as parameters when given, with their types.
OVERRIDES = {
    "setup": str,
    "target_source": str,
    "robot_source": str,
    "base_frame": str,
    "tool_frame": str,
    "size": str,
    "square": float,
    "state_dir": str,
}


def handeye_node(context):
    camera = LaunchConfiguration("camera").perform(context).rstrip("/")
    overrides = {}
    for name, kind in OVERRIDES.items():
        value = LaunchConfiguration(name).perform(context)
        if value:
            overrides[name] = kind(value)
    return [
        Node(
            executable=LaunchConfiguration("handeye_node"),
            name="handeye_node",
            namespace="/",
            parameters=[LaunchConfiguration("params_file"), overrides],
            remappings=[
                ("image", f"{camera}/image_raw"),
                ("camera_info", f"{camera}/camera_info"),
                ("target_pose", f"{camera}/target_pose"),
                ("robot_pose", LaunchConfiguration("robot_pose").perform(context)),
            ],
            output="screen",
        )
    ]


def generate_launch_description():
    described = {
        "setup": "eye_in_hand or eye_to_hand (over the params file)",
        "target_source": "image or pose (over the params file)",
        "robot_source": "tf or topic (over the params file)",
        "base_frame": "the robot's base frame (over the params file)",
        "tool_frame": "the robot's tool frame (over the params file)",
        "size": "board size COLSxROWS (over the params file)",
        "square": "square side, metres (over the params file)",
        "state_dir": "folder where samples persist (over the params file)",
    }
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "handeye_node",
                default_value="handeye_node",
                description="handeye_node executable (a path, or a name on PATH)",
            ),
            DeclareLaunchArgument(
                "camera",
                default_value="/camera",
                description="namespace of the camera's topics",
            ),
            DeclareLaunchArgument(
                "robot_pose",
                default_value="/robot/tool_pose",
                description="robot_source topic: the PoseStamped topic of base_from_tool",
            ),
            *[
                DeclareLaunchArgument(name, default_value="", description=description)
                for name, description in described.items()
            ],
            DeclareLaunchArgument(
                "params_file",
                default_value=PARAMS_FILE,
                description="ROS 2 params file for the node",
            ),
            OpaqueFunction(function=handeye_node),
        ]
    )
