"""stereocal's launch files start the graph they describe, checked by real ROS 2.

`launch` and `launch_ros` are not on PyPI, so interop/launch_harness.py evaluates each
launch file with launch arguments as `ros2 launch` would, and gives the command line
launch_ros builds for every node it starts (executable, `__node`, `__ns`, params files,
remaps). This check runs exactly those commands on a ROS domain of its own and asks
rclpy on Fast DDS whether the graph is the one the launch file documents: the nodes'
names and namespaces, the topics they subscribe and publish, the services they call,
and the parameter values from the params file and the launch arguments. Every node must
then stop cleanly on SIGTERM, as it does when `ros2 launch` is interrupted.

Usage (after `cargo build --bin rectify_node --bin calibrate_node --bin pose_node --bin handeye_node
--bin disparity_node --bin point_cloud_node --bin camera_node --bin stereocal`):
    .venv/bin/python interop/check_launch_rclpy.py
"""

import argparse
import os
import sys
import tempfile
from pathlib import Path

import yaml
from launch_harness import evaluate, overridden
from ros2_rclpy import Checks, DomainLease, NodeProcess, Parameters, Peer, require

ROOT = Path(__file__).resolve().parent.parent

#: What the rectify cases' params file sets: not the nodes' defaults (1 and 5), so the
#: values prove the file reached the nodes.
RECTIFY_PARAMS = {"interpolation": 2, "queue_size": 3}
#: Launch arguments that only say where an executable is (left out of the check names).
EXECUTABLES = {"rectify_node", "calibrate_node", "pose_node", "handeye_node", "disparity_node",
               "point_cloud_node", "camera_node", "stereocal", "params_file",
               "rectify_params_file"}
#: The params file launch/pose.launch.py gives pose_node by default.
POSE_PARAMS_FILE = ROOT / "config" / "pose_node.yaml"


def rectify_params_file(workdir):
    """A params file for every rectify_node with RECTIFY_PARAMS."""
    path = Path(workdir) / "rectify_params.yaml"
    path.write_text(yaml.safe_dump({"/**/rectify_node": {"ros__parameters": RECTIFY_PARAMS}}))
    return str(path)


def pose_file_parameters():
    """What config/pose_node.yaml sets: its `size` and `square` are not the node's
    defaults (none), so the values prove the file reached the node."""
    return yaml.safe_load(POSE_PARAMS_FILE.read_text())["/**/pose_node"]["ros__parameters"]


def pose_graph(camera, image, values):
    """pose_node in `camera` reading `camera`/`image`, as launch/pose.launch.py starts it."""
    return {
        f"{camera}/pose_node": (
            {f"{camera}/{image}": "sensor_msgs/msg/Image",
             f"{camera}/camera_info": "sensor_msgs/msg/CameraInfo"},
            {f"{camera}/target_pose": "geometry_msgs/msg/PoseStamped",
             f"{camera}/target_pose_with_covariance":
                 "geometry_msgs/msg/PoseWithCovarianceStamped",
             # By name: rclpy has no tf2_msgs, and needs none to read the graph.
             "/tf": "tf2_msgs/msg/TFMessage",
             f"{camera}/pose_node/status": "std_msgs/msg/String",
             f"{camera}/pose_node/annotated_image": "sensor_msgs/msg/Image"},
            {},
            values,
        )
    }


def handeye_graph(camera, robot_pose, values):
    """handeye_node as launch/handeye.launch.py starts it: the camera's images, the
    robot's poses from /tf or from `robot_pose` when given, its status and /tf_static."""
    robot = ({robot_pose: "geometry_msgs/msg/PoseStamped"} if robot_pose else
             {"/tf": "tf2_msgs/msg/TFMessage", "/tf_static": "tf2_msgs/msg/TFMessage"})
    return {
        "/handeye_node": (
            {f"{camera}/image_raw": "sensor_msgs/msg/Image",
             f"{camera}/camera_info": "sensor_msgs/msg/CameraInfo", **robot},
            {"/handeye_node/status": "std_msgs/msg/String",
             "/tf_static": "tf2_msgs/msg/TFMessage"},
            {},
            values,
        )
    }


#: The params file launch/stereo_depth.launch.py gives both depth nodes by default.
DEPTH_PARAMS_FILE = ROOT / "config" / "stereo_depth.yaml"


def depth_graph(camera, disparity_range):
    """disparity_node and point_cloud_node in `camera`, as launch/stereo_depth.launch.py
    starts them, with config/stereo_depth.yaml's values (its disparity_range, 128, is
    not the node's default, 64) and `disparity_range` over it."""
    params = yaml.safe_load(DEPTH_PARAMS_FILE.read_text())
    disparity = {**params["/**/disparity_node"]["ros__parameters"],
                 "disparity_range": disparity_range}
    cloud = params["/**/point_cloud_node"]["ros__parameters"]
    pair = {f"{camera}/{side}/{name}": kind
            for side in ("left", "right")
            for name, kind in (("image_rect", "sensor_msgs/msg/Image"),
                               ("camera_info", "sensor_msgs/msg/CameraInfo"))}
    return {
        f"{camera}/disparity_node": (
            pair, {f"{camera}/disparity": "stereo_msgs/msg/DisparityImage"}, {}, disparity),
        f"{camera}/point_cloud_node": (
            {f"{camera}/left/image_rect": "sensor_msgs/msg/Image",
             f"{camera}/left/camera_info": "sensor_msgs/msg/CameraInfo",
             f"{camera}/right/camera_info": "sensor_msgs/msg/CameraInfo",
             f"{camera}/disparity": "stereo_msgs/msg/DisparityImage"},
            {f"{camera}/points2": "sensor_msgs/msg/PointCloud2"}, {}, cloud),
    }


#: The params file launch/camera.launch.py and launch/stereo_camera.launch.py give
#: camera_node by default.
CAMERA_PARAMS_FILE = ROOT / "config" / "camera_node.yaml"


def camera_graph(namespace, values, partner=None):
    """camera_node in `namespace`, as launch/camera.launch.py and
    launch/stereo_camera.launch.py start it, with config/camera_node.yaml's values and
    `values` over them; subscribing `partner` (a stereo partner's camera_info)."""
    params = yaml.safe_load(CAMERA_PARAMS_FILE.read_text())["/**/camera_node"]["ros__parameters"]
    return {
        f"{namespace}/camera_node": (
            {partner: "sensor_msgs/msg/CameraInfo"} if partner else {},
            {f"{namespace}/image_raw": "sensor_msgs/msg/Image",
             f"{namespace}/image_raw/compressed": "sensor_msgs/msg/CompressedImage",
             f"{namespace}/camera_info": "sensor_msgs/msg/CameraInfo",
             f"{namespace}/camera_node/status": "std_msgs/msg/String"},
            {},
            {**params, **values},
        )
    }


def cases(rectify_node, calibrate_node, pose_node, handeye_node, disparity_node,
          point_cloud_node, camera_node, stereocal, rectify_params):
    """(launch file, launch arguments, processes started, {node: (subscribed,
    published, called services, parameter values)}) for every launch file, as its
    documentation describes it."""
    stereo_rectify = {
        f"/{side}/rectify_node": (
            {f"/my_stereo/{side}/image_raw": "sensor_msgs/msg/Image",
             f"/my_stereo/{side}/camera_info": "sensor_msgs/msg/CameraInfo"},
            {f"/my_stereo/{side}/image_rect": "sensor_msgs/msg/Image"},
            {},
            RECTIFY_PARAMS,
        )
        for side in ("left", "right")
    }
    calibrate_stereo = {
        "/stereo/calibrate_node": (
            {"/stereo/left/image_raw": "sensor_msgs/msg/Image",
             "/stereo/right/image_raw": "sensor_msgs/msg/Image"},
            {"/stereo/calibrate_node/status": "std_msgs/msg/String"},
            {"/stereo/left/set_camera_info": "sensor_msgs/srv/SetCameraInfo",
             "/stereo/right/set_camera_info": "sensor_msgs/srv/SetCameraInfo"},
            {"stereo": True, "size": "8x6", "square": 0.03, "slop": 0.01, "pattern": "chessboard",
             "queue_size": 5},
        )
    }
    calibrate_mono = {
        "/camera/calibrate_node": (
            {"/camera/image_raw": "sensor_msgs/msg/Image"},
            {"/camera/calibrate_node/status": "std_msgs/msg/String",
             "/camera/calibrate_node/annotated_image": "sensor_msgs/msg/Image"},
            {"/camera/set_camera_info": "sensor_msgs/srv/SetCameraInfo"},
            {"stereo": False, "size": "9x6", "square": 0.025, "model": "plumb_bob"},
        )
    }
    composed = {
        f"/stereo/{side}/rectify_node": (
            {f"/stereo/{side}/image_raw": "sensor_msgs/msg/Image",
             f"/stereo/{side}/camera_info": "sensor_msgs/msg/CameraInfo"},
            {f"/stereo/{side}/image_rect": "sensor_msgs/msg/Image"},
            {},
            RECTIFY_PARAMS,
        )
        for side in ("left", "right")
    }
    return [
        ("stereo_rectify.launch.py", {"rectify_node": rectify_node, "camera": "/my_stereo",
                                      "params_file": rectify_params},
         ["/left/rectify_node", "/right/rectify_node"], stereo_rectify),
        ("calibrate.launch.py", {"calibrate_node": calibrate_node, "stereo": "true", "camera": "/stereo",
                                 "size": "8x6", "square": "0.03", "slop": "0.01"},
         ["/stereo/calibrate_node"], calibrate_stereo),
        ("calibrate.launch.py", {"calibrate_node": calibrate_node}, ["/camera/calibrate_node"], calibrate_mono),
        ("stereo_rectify_composed.launch.py", {"stereocal": stereocal, "params_file": rectify_params},
         ["stereocal (composition)"], composed),
        ("pose.launch.py", {"pose_node": pose_node}, ["/camera/pose_node"],
         pose_graph("/camera", "image_raw", pose_file_parameters())),
        ("pose.launch.py", {"pose_node": pose_node, "camera": "/my_camera", "rectified": "true",
                            "size": "8x6", "square": "0.108", "target_frame": "board"},
         ["/my_camera/pose_node"],
         pose_graph("/my_camera", "image_rect", {
             **pose_file_parameters(), "size": "8x6", "square": 0.108, "target_frame": "board",
             "image_is_rectified": True})),
        ("handeye.launch.py", {"handeye_node": handeye_node}, ["/handeye_node"],
         handeye_graph("/camera", None, {
             "setup": "eye_in_hand", "robot_source": "tf", "base_frame": "base_link",
             "tool_frame": "tool0", "size": "9x6", "square": 0.025})),
        ("handeye.launch.py", {"handeye_node": handeye_node, "setup": "eye_to_hand",
                               "camera": "/scene_camera", "robot_source": "topic",
                               "size": "8x6", "square": "0.03"},
         ["/handeye_node"],
         handeye_graph("/scene_camera", "/robot/tool_pose", {
             "setup": "eye_to_hand", "robot_source": "topic", "size": "8x6", "square": 0.03})),
        ("stereo_depth.launch.py", {"disparity_node": disparity_node,
                                    "point_cloud_node": point_cloud_node},
         ["/stereo/disparity_node", "/stereo/point_cloud_node"], depth_graph("/stereo", 128)),
        ("stereo_pipeline_composed.launch.py", {"stereocal": stereocal,
                                                "rectify_params_file": rectify_params},
         ["stereocal (composition)"], {**composed, **depth_graph("/stereo", 128)}),
        ("stereo_depth.launch.py", {"disparity_node": disparity_node,
                                    "point_cloud_node": point_cloud_node,
                                    "camera": "/my_stereo", "disparity_range": "96"},
         ["/my_stereo/disparity_node", "/my_stereo/point_cloud_node"],
         depth_graph("/my_stereo", 96)),
        ("camera.launch.py", {"camera_node": camera_node, "video_device": "test_pattern"},
         ["/camera/camera_node"],
         camera_graph("/camera", {"video_device": "test_pattern", "camera_name": "camera",
                                  "frame_id": "camera_optical_frame"})),
        ("camera.launch.py", {"camera_node": camera_node, "camera": "/front",
                              "video_device": "test_pattern", "pixel_format": "MJPEG",
                              "image_width": "320", "image_height": "240", "framerate": "15",
                              "camera_name": "front"},
         ["/front/camera_node"],
         camera_graph("/front", {"video_device": "test_pattern", "pixel_format": "MJPEG",
                                 "image_width": 320, "image_height": 240, "framerate": 15.0,
                                 "camera_name": "front"})),
        ("stereo_camera.launch.py", {"camera_node": camera_node, "left_device": "test_pattern",
                                     "right_device": "test_pattern", "image_width": "320",
                                     "image_height": "240"},
         ["/stereo/left/camera_node", "/stereo/right/camera_node"],
         {**camera_graph("/stereo/left", {
             "video_device": "test_pattern", "camera_name": "left", "image_width": 320,
             "image_height": 240, "frame_id": "left_camera_optical_frame",
             "stereo_partner": ""}),
          **camera_graph("/stereo/right", {
              "video_device": "test_pattern", "camera_name": "right", "image_width": 320,
              "image_height": 240, "frame_id": "right_camera_optical_frame",
              "stereo_partner": "/stereo/left/camera_info"},
              partner="/stereo/left/camera_info")}),
    ]


def split(name):
    namespace, _, node = name.rpartition("/")
    return node, namespace or "/"


def process_label(launch):
    """How a started process is named in the check: its node, or its executable when
    the launch file gives no node name (a composition names its own nodes)."""
    if launch.name:
        return f"{(launch.namespace or '').rstrip('/')}/{launch.name}"
    return f"{Path(launch.executable).name} (composition)"


def check_case(checks, launch_file, arguments, processes, expected, workdir):
    shown = " ".join(f"{k}:={v}" for k, v in arguments.items() if k not in EXECUTABLES)
    label = f"{launch_file} {shown or '(defaults)'}"
    with checks.check(label, "evaluates: the nodes it starts") as note:
        evaluation = evaluate(str(ROOT / "launch" / launch_file), arguments)
        started = sorted(process_label(n) for n in evaluation.nodes)
        require(started == sorted(processes), f"starts {started}, documented {sorted(processes)}")
        note(", ".join(started))
    if not checks.passed(label, "evaluates: the nodes it starts"):
        return
    lease = DomainLease()
    peer = Peer(lease.id, name="launch_check")
    # What the launch file sets in the environment, its processes get.
    with overridden(os.environ, evaluation.environment):
        node_processes = [NodeProcess(n.command(workdir), lease.id) for n in evaluation.nodes]
    for process in node_processes:
        peer.watch(process)
    try:
        with checks.check(label, "graph: nodes, topics, services called") as note:
            for name, (subscribed, published, called, _) in expected.items():
                node, namespace = split(name)
                peer.wait_until(lambda: (node, namespace) in peer.node_names(), f"{name} in the graph")

                def entities_complete():
                    entities = peer.entities_of(node, namespace)
                    return entities if (set(subscribed) <= set(entities["subscribers"])
                                        and set(published) <= set(entities["publishers"])
                                        and set(called) <= set(entities["clients"])) else None
                entities = peer.wait_until(entities_complete, lambda: f"{name}'s topics and clients: "
                                           f"{peer.entities_of(node, namespace)}")
                for kind, wanted in (("subscribers", subscribed), ("publishers", published),
                                     ("clients", called)):
                    for topic, type_name in wanted.items():
                        require(entities[kind][topic] == [type_name],
                                f"{name} {kind} {topic}: {entities[kind][topic]}, expected {type_name}")
            note(f"{len(expected)} node(s) as documented")
        with checks.check(label, "parameters: params file and launch arguments") as note:
            for name, (_, _, _, values) in expected.items():
                got = Parameters(peer, name).get(list(values))
                typed = [(type(v), v) for v in got]
                require(typed == [(type(v), v) for v in values.values()],
                        f"{name}: {dict(zip(values, got))}, expected {values}")
            note("; ".join(f"{name}: {values}" for name, (_, _, _, values) in expected.items()))
        with checks.check(label, "clean shutdown (SIGTERM)"):
            peer.watched.clear()
            codes = [p.stop() for p in node_processes]
            require(all(code == 0 for code in codes), lambda: f"exit codes {codes}:\n"
                    + "\n".join(p.logs()[-2000:] for p in node_processes))
            peer.wait_until(lambda: not ({split(n) for n in expected} & peer.node_names()),
                            "the nodes to leave the graph")
    finally:
        for process in node_processes:
            process.stop()
        peer.close()
        lease.release()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rectify-node", default=str(ROOT / "target" / "debug" / "rectify_node"))
    parser.add_argument("--calibrate-node", default=str(ROOT / "target" / "debug" / "calibrate_node"))
    parser.add_argument("--pose-node", default=str(ROOT / "target" / "debug" / "pose_node"))
    parser.add_argument("--handeye-node", default=str(ROOT / "target" / "debug" / "handeye_node"))
    parser.add_argument("--disparity-node", default=str(ROOT / "target" / "debug" / "disparity_node"))
    parser.add_argument("--point-cloud-node",
                        default=str(ROOT / "target" / "debug" / "point_cloud_node"))
    parser.add_argument("--camera-node", default=str(ROOT / "target" / "debug" / "camera_node"))
    parser.add_argument("--stereocal", default=str(ROOT / "target" / "debug" / "stereocal"))
    args = parser.parse_args()
    for binary in (args.rectify_node, args.calibrate_node, args.pose_node, args.handeye_node,
                   args.disparity_node, args.point_cloud_node, args.camera_node, args.stereocal):
        if not Path(binary).exists():
            sys.exit(f"{binary} not found; build it with `cargo build --bin rectify_node "
                     "--bin calibrate_node --bin pose_node --bin handeye_node "
                     "--bin disparity_node --bin point_cloud_node --bin camera_node "
                     "--bin stereocal`")
    checks = Checks()
    with tempfile.TemporaryDirectory() as workdir:
        # calibrate_node keeps its samples under $ROS_HOME: a folder of this check's own.
        os.environ["ROS_HOME"] = workdir
        for launch_file, arguments, processes, expected in cases(
                args.rectify_node, args.calibrate_node, args.pose_node, args.handeye_node,
                args.disparity_node, args.point_cloud_node, args.camera_node, args.stereocal,
                rectify_params_file(workdir)):
            check_case(checks, launch_file, arguments, processes, expected, workdir)
    return checks.table()


if __name__ == "__main__":
    sys.exit(main())
