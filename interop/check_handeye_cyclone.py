"""Cyclone DDS feeds stereocal's handeye_node /tf and receives its result on /tf_static.

rclpy has no tf2_msgs wheel, so the robot's transforms and the result on /tf are
exchanged with an independent DDS implementation, Cyclone DDS's Python binding (the IDL
types of interop/ros2_cyclone.py); real ROS 2, rclpy on Fast DDS
(interop/ros2_rclpy.py), calls the node's services and reads its `~/status`, as an
operator's script would. Both run in this process on one ROS domain leased for the run.

Synthesizes an eye-in-hand session with `stereocal synth` (its robot standing still
around each frame, its poses on /tf at 100 Hz), starts handeye_node with
`robot_source: tf`, and for each frame publishes with Cyclone the robot's transforms up
to just after the frame, then the image and camera_info, until the status shows the
node's verdict on it; rclpy's `~/take_sample` keeps it. `~/compute` must then put
`tool -> camera_optical_frame` on /tf_static (reliable, transient local: a Cyclone
reader created after it still receives it), equal (1e-9) to `stereocal handeye --json
--tf base:tool` on the same bag and within three of its predicted standard deviations of
the ground truth. Ends the node with SIGTERM and checks that it exits cleanly. Exits
non-zero on any failure.

Usage (after `cargo build --bin handeye_node --bin stereocal`):
    .venv/bin/python interop/check_handeye_cyclone.py [--node target/debug/handeye_node]
        [--stereocal target/debug/stereocal]
"""

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path

# ros2_rclpy first: it chooses the middleware before rclpy loads one.
from ros2_rclpy import DomainLease, NodeProcess, Peer
import cv2
import numpy as np
from bag_images import messages
from check_pose_cyclone import cyclone_frame
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from pose_session import CAMERA_INFO, IMAGE_RAW, rotation_of, synthesize
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros2_cyclone import (
    CameraInfo, Header, Image, Quaternion, TFMessage, Time, Transform, TransformStamped,
    Vector3, fail, reliable_qos,
)

from std_msgs.msg import String

ROOT = Path(__file__).resolve().parent.parent
FRAMES = 6
NODE = "/handeye_node"
STATUS_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: Largest difference from `stereocal handeye`'s result, per rotation entry and metre.
OFFLINE_TOLERANCE = 1e-9


def seconds(stamp):
    return stamp.sec + stamp.nanosec * 1e-9


def cyclone_tf(message):
    """A rosbags tf2_msgs/TFMessage as Cyclone's."""
    return TFMessage(transforms=[
        TransformStamped(
            header=Header(stamp=Time(sec=t.header.stamp.sec, nanosec=t.header.stamp.nanosec),
                          frame_id=t.header.frame_id),
            child_frame_id=t.child_frame_id,
            transform=Transform(
                translation=Vector3(x=t.transform.translation.x, y=t.transform.translation.y,
                                    z=t.transform.translation.z),
                rotation=Quaternion(x=t.transform.rotation.x, y=t.transform.rotation.y,
                                    z=t.transform.rotation.z, w=t.transform.rotation.w)))
        for t in message.transforms])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--node", default=str(ROOT / "target" / "debug" / "handeye_node"))
    parser.add_argument("--stereocal", default=str(ROOT / "target" / "debug" / "stereocal"))
    args = parser.parse_args()
    for binary in (args.node, args.stereocal):
        if not Path(binary).exists():
            fail(f"{binary} not found; build it with `cargo build --bin handeye_node "
                 "--bin stereocal`")
    lease = DomainLease()
    peer = Peer(lease.id)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            run(args, lease.id, peer, Path(tmp))
    finally:
        peer.close()
        lease.release()


def run(args, domain, peer, tmp):
    try:
        session = synthesize(args.stereocal, tmp, frames=FRAMES)
    except RuntimeError as e:
        fail(str(e))
    frames = [cyclone_frame(*f) for f in session.frames()]
    tf = [cyclone_tf(m) for _, m in messages(session.bag, ("/tf",))]
    size, square = session.size_parameters()
    offline = subprocess.run(
        [args.stereocal, "handeye", "--bag", str(session.bag), "--setup", "eye-in-hand",
         "--image-topic", IMAGE_RAW, "--size", size, "--square", str(square), "--tf", "base:tool",
         "--out", str(tmp / "offline"), "--json"], capture_output=True, text=True)
    if offline.returncode != 0:
        fail(f"stereocal handeye failed:\n{offline.stderr}")
    offline = json.loads(offline.stdout)
    truth = json.loads((tmp / "scene" / "ground_truth.json").read_text())

    node = NodeProcess([args.node, "--ros-args", "-r", f"image:={IMAGE_RAW}",
                        "-r", f"camera_info:={CAMERA_INFO}", "-p", "robot_source:=tf",
                        "-p", "base_frame:=base", "-p", "tool_frame:=tool",
                        "-p", f"size:={size}", "-p", f"square:={square}",
                        "-p", f"state_dir:={tmp / 'state'}"], domain)
    peer.watch(node)
    status = peer.subscribe(String, f"{NODE}/status", STATUS_QOS)

    def last_status():
        return json.loads(status.last.data) if status.last else None

    participant = DomainParticipant(domain)
    image_writer = DataWriter(participant, Topic(participant, f"rt{IMAGE_RAW}", Image),
                              reliable_qos(10))
    info_writer = DataWriter(participant, Topic(participant, f"rt{CAMERA_INFO}", CameraInfo),
                             reliable_qos(10))
    tf_writer = DataWriter(participant, Topic(participant, "rt/tf", TFMessage), reliable_qos(1000))
    try:
        peer.wait_until(last_status, f"{NODE}/status")
        peer.wait_until(lambda: image_writer.get_matched_subscriptions()
                        and tf_writer.get_matched_subscriptions(),
                        "handeye_node's image and /tf readers")
        sent = 0
        for k, (image, info) in enumerate(frames):
            stamp = seconds(image.header.stamp)
            while sent < len(tf) and seconds(tf[sent].transforms[0].header.stamp) <= stamp + 0.1:
                tf_writer.write(tf[sent])
                sent += 1

            def judged():
                latest = (last_status() or {}).get("latest")
                return latest if latest and latest["stamp"] == stamp else None

            def send():
                info_writer.write(info)
                image_writer.write(image)
            latest = peer.send_until(send, judged, f"a verdict on the frame at {stamp} s")
            if not latest["ready"]:
                fail(f"frame {k}: {latest}")
            taken = peer.trigger(f"{NODE}/take_sample")
            if not taken.success:
                fail(f"frame {k}: {taken.message}")
        computed = peer.trigger(f"{NODE}/compute")
        if not computed.success:
            fail(f"~/compute: {computed.message}")
        # A reader made after the result was published: transient local brings it.
        tf_static = DataReader(participant, Topic(participant, "rt/tf_static", TFMessage),
                               reliable_qos(10, transient_local=True))
        received = []
        deadline = time.monotonic() + 60
        while not received:
            received += [t for m in tf_static.take(N=10) for t in m.transforms]
            if time.monotonic() > deadline:
                fail("no /tf_static transform in 60 s")
            time.sleep(0.01)
        check_result(received[0], offline, truth, sent)
    finally:
        node.stop()
    if node.process.returncode != 0 or node.panic():
        fail(f"handeye_node exited with {node.process.returncode}:\n{node.logs()[-3000:]}")


def check_result(transform, offline, truth, sent):
    names = (transform.header.frame_id, transform.child_frame_id)
    if names != ("tool", "camera_optical_frame"):
        fail(f"/tf_static {names[0]} -> {names[1]}, expected tool -> camera_optical_frame")
    t = transform.transform
    rotation = rotation_of(t.rotation)
    translation = [t.translation.x, t.translation.y, t.translation.z]
    result = offline["results"][offline["chosen"]]
    difference = max(float(np.abs(rotation.ravel() - result["rotation"]).max()),
                     float(np.abs(np.subtract(translation, result["translation"])).max()))
    if difference > OFFLINE_TOLERANCE:
        fail(f"/tf_static differs from stereocal handeye ({offline['chosen']}) by {difference:.3g}")
    true = truth["extrinsics"]["tool_from_camera"]
    angle, _ = cv2.Rodrigues(rotation @ np.reshape(true["rotation_row_major"], (3, 3)).T)
    degrees = float(np.degrees(np.linalg.norm(angle)))
    mm = float(np.linalg.norm(np.subtract(translation, true["translation_m"])) * 1e3)
    u = offline["uncertainty"]
    if degrees >= 3 * u["rotation_deg"] or mm >= 3 * u["translation_mm"]:
        fail(f"/tf_static is {degrees:.4f} deg, {mm:.3f} mm from the truth; predicted {u}")
    print(f"OK: Cyclone DDS sent {sent} /tf messages and {FRAMES} frames to handeye_node; rclpy "
          f"took {FRAMES} samples and computed; a late Cyclone reader received /tf_static tool -> "
          f"camera_optical_frame, {difference:.1g} from stereocal handeye --tf "
          f"({offline['chosen']}), {degrees:.4f} deg and {mm:.3f} mm from the truth (predicted "
          f"{u['rotation_deg']:.4f} deg, {u['translation_mm']:.3f} mm); clean SIGTERM exit")


if __name__ == "__main__":
    main()
