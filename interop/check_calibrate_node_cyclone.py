"""Cyclone DDS drives stereocal's calibrate_node: an independent DDS implementation.

Synthesizes a stereo calibration session with `stereocal synth`, reads its bag with
`rosbags`, starts calibrate_node (stereo, exact sync) on its own ROS domain, publishes
the pairs on `rt/stereo/left/image_raw` and `rt/stereo/right/image_raw` with Cyclone
DDS's Python binding (ROS 2's DDS type names, plain CDR), and reads
`rt/stereo/calibrate_node/status` (std_msgs/String, reliable, transient local) the same
way: every pair must be judged, the status must be the progress JSON with both cameras,
and samples must be kept. Ends the node with SIGTERM and checks that it exits cleanly.
Exits non-zero on any failure.

Usage (after `cargo build --bin calibrate_node --bin stereocal`):
    .venv/bin/python interop/check_calibrate_node_cyclone.py
"""

import argparse
import json
import os
import subprocess
import tempfile
import time
from pathlib import Path

from bag_images import messages
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from ros2_cyclone import Header, Image, String, Time, fail, reliable_qos, stop_node

ROOT = Path(__file__).resolve().parent.parent
FRAMES = 30
TIMEOUT_S = 20.0


def read_pairs(bag):
    """The bag's (left, right) images in stamp order, as Cyclone messages."""
    frames = {"/stereo/left/image_raw": [], "/stereo/right/image_raw": []}
    for topic, msg in messages(bag, frames):
        header = Header(
            stamp=Time(sec=msg.header.stamp.sec, nanosec=msg.header.stamp.nanosec),
            frame_id=msg.header.frame_id,
        )
        frames[topic].append(Image(
            header=header, height=msg.height, width=msg.width, encoding=msg.encoding,
            is_bigendian=msg.is_bigendian, step=msg.step, data=bytes(msg.data),
        ))
    return list(zip(frames["/stereo/left/image_raw"], frames["/stereo/right/image_raw"]))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--node", default=str(ROOT / "target" / "debug" / "calibrate_node"))
    parser.add_argument("--stereocal", default=str(ROOT / "target" / "debug" / "stereocal"))
    parser.add_argument("--domain", type=int, default=180 + os.getpid() % 50)
    args = parser.parse_args()
    for binary in (args.node, args.stereocal):
        if not Path(binary).exists():
            fail(f"{binary} not found; build it with `cargo build --bin calibrate_node --bin stereocal`")

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        subprocess.run(
            [args.stereocal, "synth", "--scene", "calibration", "--frames", str(FRAMES),
             "--width", "640", "--height", "480", "--out", str(tmp / "scene")],
            check=True, stdout=subprocess.DEVNULL,
        )
        pairs = read_pairs(tmp / "scene" / "bag")
        if len(pairs) != FRAMES:
            fail(f"the synthesized bag has {len(pairs)} pairs, not {FRAMES}")
        env = dict(os.environ, ROS_DOMAIN_ID=str(args.domain))
        node = subprocess.Popen(
            [args.node, "--ros-args", "-r", "__ns:=/stereo",
             "-r", "left/image:=left/image_raw", "-r", "right/image:=right/image_raw",
             "-p", "stereo:=true", "-p", "size:=9x6", "-p", "square:=0.025",
             "-p", f"state_dir:={tmp / 'state'}"],
            env=env, stderr=subprocess.PIPE, text=True,
        )
        try:
            status = check(args.domain, pairs)
        finally:
            stderr = stop_node(node, "calibrate_node")
        if node.returncode != 0:
            fail(f"calibrate_node exited with {node.returncode}:\n{stderr}")
    print(f"OK: Cyclone DDS sent {FRAMES} pairs to calibrate_node, which judged every one "
          f"and kept {status['samples']} samples; clean SIGTERM exit")


def check(domain, pairs):
    participant = DomainParticipant(domain)
    writer_qos = reliable_qos(10)
    status_qos = reliable_qos(10, transient_local=True)
    left = DataWriter(participant, Topic(participant, "rt/stereo/left/image_raw", Image), writer_qos)
    right = DataWriter(participant, Topic(participant, "rt/stereo/right/image_raw", Image), writer_qos)
    status_reader = DataReader(
        participant, Topic(participant, "rt/stereo/calibrate_node/status", String), status_qos)

    latest = {}

    def poll():
        for sample in status_reader.take(N=100):
            latest.update(json.loads(sample.data))

    deadline = time.monotonic() + TIMEOUT_S
    while not latest:
        if time.monotonic() > deadline:
            fail("no status from calibrate_node")
        poll()
        time.sleep(0.05)
    if [c["name"] for c in latest["cameras"]] != ["left", "right"]:
        fail(f"status names cameras {latest['cameras']}")
    for writer in (left, right):
        deadline = time.monotonic() + TIMEOUT_S
        while not writer.get_matched_subscriptions():
            if time.monotonic() > deadline:
                fail("calibrate_node's image readers did not match")
            time.sleep(0.05)

    for index, (left_image, right_image) in enumerate(pairs):
        judged = latest["frames"]["judged"]
        deadline = time.monotonic() + TIMEOUT_S
        resend = 0.0
        while latest["frames"]["judged"] <= judged:
            if time.monotonic() > deadline:
                fail(f"pair {index} was not judged: {latest}")
            if time.monotonic() > resend:
                left.write(left_image)
                right.write(right_image)
                resend = time.monotonic() + 1.0
            time.sleep(0.01)
            poll()
    if latest["frames"]["judged"] < FRAMES or latest["samples"] == 0:
        fail(f"after {FRAMES} pairs: {latest}")
    return latest


if __name__ == "__main__":
    main()
