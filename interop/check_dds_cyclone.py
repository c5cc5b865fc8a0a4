"""Cyclone DDS talks to stereocal's rectify_node: an independent DDS implementation.

Starts the rectify_node binary on its own ROS domain, publishes sensor_msgs/Image and
sensor_msgs/CameraInfo on `rt/cam/image_raw` and `rt/cam/camera_info` with Cyclone
DDS's Python binding (the IDL types of interop/ros2_cyclone.py, with ROS 2's DDS type
names such as `sensor_msgs::msg::dds_::Image_`, and plain CDR as ROS 2 uses), receives
`rt/cam/image_rect` the same way, and checks every frame: type, header, encoding, size,
and pixels against OpenCV's initUndistortRectifyMap + remap (bilinear) within 1 grey
level. Ends the node with SIGTERM and checks that it exits cleanly. Exits non-zero on
any failure.

Usage (after `cargo build --bin rectify_node`):
    .venv/bin/python interop/check_dds_cyclone.py [--node target/debug/rectify_node]
"""

import argparse
import os
import re
import subprocess
import time
from pathlib import Path

import numpy as np
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from rectify_scene import D, HEIGHT, K, P, R, WIDTH, opencv_rectified, pixels
from ros2_cyclone import (
    CameraInfo, Header, Image, RegionOfInterest, Time, fail, reliable_qos, stop_node,
)

ROOT = Path(__file__).resolve().parent.parent
FRAMES = 10
TIMEOUT_S = 20.0


def camera_info(header):
    return CameraInfo(
        header=header, height=HEIGHT, width=WIDTH, distortion_model="plumb_bob",
        d=D, k=K, r=R, p=P, binning_x=0, binning_y=0,
        roi=RegionOfInterest(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False),
    )


def image(header, raw):
    channels = raw.shape[2]
    return Image(
        header=header, height=HEIGHT, width=WIDTH,
        encoding="rgb8" if channels == 3 else "mono8", is_bigendian=0,
        step=WIDTH * channels, data=raw.tobytes(),
    )


def wait_until(condition, what):
    deadline = time.monotonic() + TIMEOUT_S
    while not condition():
        if time.monotonic() > deadline:
            fail(f"timed out waiting for {what}")
        time.sleep(0.05)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--node", default=str(ROOT / "target" / "debug" / "rectify_node"))
    parser.add_argument("--domain", type=int, default=180 + os.getpid() % 50)
    args = parser.parse_args()
    if not Path(args.node).exists():
        fail(f"{args.node} not found; build it with `cargo build --bin rectify_node`")

    env = dict(os.environ, ROS_DOMAIN_ID=str(args.domain))
    node = subprocess.Popen(
        [args.node, "--ros-args", "-r", "__ns:=/cam", "-r", "image:=image_raw"],
        env=env,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        check(args.domain)
    finally:
        stderr = stop_node(node, "rectify_node")
    if node.returncode != 0:
        fail(f"rectify_node exited with {node.returncode}:\n{stderr}")
    summary = re.search(
        r"(\d+) frame\(s\) received, (\d+) published \((\d+) over DDS\), (\d+) dropped", stderr)
    if not summary or summary[1] != summary[2] or summary[4] != "0":
        fail(f"rectify_node did not publish every frame it received:\n{stderr}")
    print(f"OK: Cyclone DDS exchanged {FRAMES} frames with rectify_node; clean SIGTERM exit")


def check(domain):
    participant = DomainParticipant(domain)
    writer_qos = reliable_qos(10)
    reader_qos = reliable_qos(50)
    image_writer = DataWriter(participant, Topic(participant, "rt/cam/image_raw", Image), writer_qos)
    info_writer = DataWriter(participant, Topic(participant, "rt/cam/camera_info", CameraInfo), writer_qos)
    rect_reader = DataReader(participant, Topic(participant, "rt/cam/image_rect", Image), reader_qos)

    wait_until(lambda: len(image_writer.get_matched_subscriptions()) > 0, "rectify_node's image reader")
    wait_until(lambda: len(info_writer.get_matched_subscriptions()) > 0, "rectify_node's camera_info reader")
    wait_until(lambda: len(rect_reader.get_matched_publications()) > 0, "rectify_node's image_rect writer")

    # A best-effort reader ignores samples of writers it has not matched yet, and our
    # writers may match first: warm up until a frame makes the round trip.
    warm_up = time.monotonic() + TIMEOUT_S
    k = 0
    while not rect_reader.take(N=FRAMES):
        if time.monotonic() > warm_up:
            fail("no frame made the round trip through rectify_node")
        header = Header(stamp=Time(sec=1, nanosec=k), frame_id="cam_optical")
        info_writer.write(camera_info(header))
        image_writer.write(image(header, pixels(0, 1)))
        k += 1
        time.sleep(0.2)
    time.sleep(0.5)
    rect_reader.take(N=100)

    sent = {}
    for i in range(1, FRAMES + 1):
        stamp = Time(sec=200, nanosec=i * 1000)
        header = Header(stamp=stamp, frame_id="cam_optical")
        channels = 3 if i % 3 == 0 else 1
        raw = pixels(i, channels)
        info_writer.write(camera_info(header))
        image_writer.write(image(header, raw))
        sent[(stamp.sec, stamp.nanosec)] = raw
        time.sleep(0.1)

    received = []
    deadline = time.monotonic() + TIMEOUT_S
    while len(received) < FRAMES and time.monotonic() < deadline:
        received.extend(r for r in rect_reader.take(N=FRAMES) if r.header.stamp.sec != 1)
        time.sleep(0.05)
    if len(received) != FRAMES:
        fail(f"received {len(received)} of {FRAMES} rectified frames")

    worst = 0
    for rect in received:
        key = (rect.header.stamp.sec, rect.header.stamp.nanosec)
        if key not in sent:
            fail(f"image_rect with unknown stamp {key}")
        raw = sent.pop(key)
        channels = raw.shape[2]
        want_encoding = "rgb8" if channels == 3 else "mono8"
        if rect.encoding != want_encoding or rect.header.frame_id != "cam_optical":
            fail(f"frame {key}: encoding {rect.encoding!r}, frame {rect.header.frame_id!r}")
        if (rect.width, rect.height, rect.step) != (WIDTH, HEIGHT, WIDTH * channels):
            fail(f"frame {key}: {rect.width}x{rect.height} step {rect.step}")
        got = np.frombuffer(bytes(rect.data), dtype=np.uint8).reshape(HEIGHT, WIDTH, channels)
        diff = np.abs(got.astype(int) - opencv_rectified(raw).astype(int))
        worst = max(worst, int(diff.max()))
    if worst > 1:
        fail(f"rectified pixels differ from OpenCV by up to {worst} grey levels")
    print(f"frames: {FRAMES}/{FRAMES}, max |rectify_node - OpenCV| = {worst} grey level(s)")


if __name__ == "__main__":
    main()
