"""Cyclone DDS receives stereocal's pose_node's /tf: an independent DDS implementation.

Synthesizes an eye-in-hand session with `stereocal synth` (interop/pose_session.py),
starts pose_node on a ROS domain leased for this run (the DomainLease of
interop/ros2_rclpy.py), publishes the frames on `rt/camera/image_raw` and
`rt/camera/camera_info` (equal stamps) with Cyclone DDS's Python binding (the IDL types
of interop/ros2_cyclone.py, with ROS 2's DDS type names and plain CDR), each frame
again until it is answered, and reads `rt/tf` (tf2_msgs/TFMessage: rclpy has no
tf2_msgs wheel, so /tf is received here) and `rt/camera/target_pose`
(geometry_msgs/PoseStamped) the same way. Every frame's transform must have the
image's frame_id as parent, `target` as child and the image's stamp, equal the
PoseStamped's pose exactly, and be within 0.05 degree and 0.5 mm of the ground truth.
Ends the node with SIGTERM and checks that it exits cleanly. Exits non-zero on any
failure.

Usage (after `cargo build --bin pose_node --bin stereocal`):
    .venv/bin/python interop/check_pose_cyclone.py [--node target/debug/pose_node]
        [--stereocal target/debug/stereocal]
"""

import argparse
import json
import os
import subprocess
import tempfile
import time
from pathlib import Path

from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from pose_session import (
    CAMERA_INFO, IMAGE_RAW, TRUTH_DEGREES, TRUTH_MM, rotation_of, synthesize, truth_error,
)
from ros2_cyclone import (
    CameraInfo, Header, Image, PoseStamped, RegionOfInterest, String, TFMessage, Time, fail,
    reliable_qos, stop_node,
)
from ros2_rclpy import DomainLease

ROOT = Path(__file__).resolve().parent.parent
#: Longest wait for progress (a reader matched, a frame answered); frames are sent
#: again every RESEND_S meanwhile, as the node reads them best-effort.
TIMEOUT_S = 60.0
RESEND_S = 2.0
TARGET_FRAME = "target"


def cyclone_frame(image, info):
    """A session frame (rosbags messages) as Cyclone's Image and CameraInfo."""
    def header(msg):
        return Header(stamp=Time(sec=msg.header.stamp.sec, nanosec=msg.header.stamp.nanosec),
                      frame_id=msg.header.frame_id)
    roi = info.roi
    return (
        Image(header=header(image), height=image.height, width=image.width,
              encoding=image.encoding, is_bigendian=image.is_bigendian, step=image.step,
              data=image.data.tobytes()),
        CameraInfo(header=header(info), height=info.height, width=info.width,
                   distortion_model=info.distortion_model, d=[float(v) for v in info.d],
                   k=[float(v) for v in info.k], r=[float(v) for v in info.r],
                   p=[float(v) for v in info.p], binning_x=info.binning_x,
                   binning_y=info.binning_y,
                   roi=RegionOfInterest(x_offset=roi.x_offset, y_offset=roi.y_offset,
                                        height=roi.height, width=roi.width,
                                        do_rectify=roi.do_rectify)),
    )


def stamp_of(msg):
    return (msg.header.stamp.sec, msg.header.stamp.nanosec)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--node", default=str(ROOT / "target" / "debug" / "pose_node"))
    parser.add_argument("--stereocal", default=str(ROOT / "target" / "debug" / "stereocal"))
    args = parser.parse_args()
    for binary in (args.node, args.stereocal):
        if not Path(binary).exists():
            fail(f"{binary} not found; build it with `cargo build --bin pose_node --bin stereocal`")

    lease = DomainLease()
    with tempfile.TemporaryDirectory() as tmp:
        try:
            session = synthesize(args.stereocal, tmp)
        except RuntimeError as e:
            fail(str(e))
        frames = [cyclone_frame(*f) for f in session.frames()]
        if len(frames) != len(session.truth):
            fail(f"the synthesized bag has {len(frames)} frames, not {len(session.truth)}")
        size, square = session.size_parameters()
        node = subprocess.Popen(
            [args.node, "--ros-args", "-r", "__ns:=/camera", "-r", "image:=image_raw",
             "-p", f"size:={size}", "-p", f"square:={square}"],
            env=dict(os.environ, ROS_DOMAIN_ID=str(lease.id)), stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        )
        try:
            worst = check(lease.id, node, frames, session)
        finally:
            stderr = stop_node(node, "pose_node")
            lease.release()
    if node.returncode != 0 or "panicked at" in stderr:
        fail(f"pose_node exited with {node.returncode}:\n{stderr}")
    print(f"OK: Cyclone DDS sent {len(frames)} frames to pose_node and received every frame's "
          f"/tf ({TARGET_FRAME} in the image's frame, at its stamp) equal to its target_pose, "
          f"at most {worst[0]:.4f} deg and {worst[1]:.3f} mm from the truth; clean SIGTERM exit")


def check(domain, node, frames, session):
    """Replays `frames` into the node; returns the worst (degrees, mm) from the truth."""
    participant = DomainParticipant(domain)
    writer_qos = reliable_qos(10)
    image_writer = DataWriter(participant, Topic(participant, f"rt{IMAGE_RAW}", Image), writer_qos)
    info_writer = DataWriter(participant, Topic(participant, f"rt{CAMERA_INFO}", CameraInfo),
                             writer_qos)
    tf_reader = DataReader(participant, Topic(participant, "rt/tf", TFMessage), reliable_qos(100))
    pose_reader = DataReader(participant, Topic(participant, "rt/camera/target_pose", PoseStamped),
                             reliable_qos(50))
    status_reader = DataReader(participant, Topic(participant, "rt/camera/pose_node/status", String),
                               reliable_qos(10, transient_local=True))
    transforms, poses, status = {}, {}, {}

    def poll():
        for sample in status_reader.take(N=100):
            status.update(json.loads(sample.data))
        for message in tf_reader.take(N=100):
            for transform in message.transforms:
                transforms.setdefault(stamp_of(transform), []).append(transform)
        for pose in pose_reader.take(N=100):
            poses.setdefault(stamp_of(pose), []).append(pose)

    def wait_until(condition, what, step=None):
        """Polls until `condition()` holds, calling `step()` (when given) every RESEND_S;
        fails after TIMEOUT_S or as soon as the node has exited."""
        deadline = time.monotonic() + TIMEOUT_S
        next_step = 0.0
        while not condition():
            if node.poll() is not None:
                fail(f"pose_node exited with {node.returncode} while waiting for {what}:\n"
                     f"{node.stderr.read()[-3000:]}")
            if time.monotonic() > deadline:
                fail(f"timed out after {TIMEOUT_S:.0f} s waiting for {what}")
            if step and time.monotonic() >= next_step:
                step()
                next_step = time.monotonic() + RESEND_S
            time.sleep(0.01)
            poll()

    wait_until(lambda: image_writer.get_matched_subscriptions()
               and info_writer.get_matched_subscriptions(),
               "pose_node's image and camera_info readers")
    wait_until(lambda: tf_reader.get_matched_publications()
               and pose_reader.get_matched_publications(),
               "pose_node's /tf and target_pose writers")

    for image, info in frames:
        stamp = stamp_of(image)

        def send():
            info_writer.write(info)
            image_writer.write(image)
        wait_until(lambda: stamp in transforms and stamp in poses,
                   f"/tf and target_pose of the frame at {stamp}", send)

    wait_until(lambda: status.get("frames", {}).get("poses") == len(frames),
               "~/status counting every pose")
    latency = status["latency_ms"]
    print(f"pose_node per frame, medians: {latency['frame']:.2f} ms in all, {latency['detection']:.2f} ms "
          f"finding the corners, {latency['pose']:.3f} ms solving the pose; "
          f"{latency['frame'] - latency['detection']:.2f} ms beyond detection")
    worst = (0.0, 0.0)
    for image, _ in frames:
        stamp = stamp_of(image)
        pose = poses[stamp][0].pose
        if any(p.pose != pose for p in poses[stamp]):
            fail(f"frame {stamp}: target_pose sent with different poses: {poses[stamp]}")
        for transform in transforms[stamp]:
            names = (transform.header.frame_id, transform.child_frame_id)
            if names != (image.header.frame_id, TARGET_FRAME):
                fail(f"frame {stamp}: transform {names[0]} -> {names[1]}, expected "
                     f"{image.header.frame_id} -> {TARGET_FRAME}")
            t = transform.transform
            translation = [t.translation.x, t.translation.y, t.translation.z]
            if (translation != [pose.position.x, pose.position.y, pose.position.z]
                    or t.rotation != pose.orientation):
                fail(f"frame {stamp}: /tf {t}, target_pose {pose}")
        degrees, mm = truth_error(rotation_of(pose.orientation),
                                  [pose.position.x, pose.position.y, pose.position.z],
                                  session.truth[stamp])
        if degrees >= TRUTH_DEGREES or mm >= TRUTH_MM:
            fail(f"frame {stamp}: {degrees:.4f} deg, {mm:.3f} mm from the truth")
        worst = (max(worst[0], degrees), max(worst[1], mm))
    return worst


if __name__ == "__main__":
    main()
