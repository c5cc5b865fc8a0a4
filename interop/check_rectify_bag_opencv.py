"""`stereocal rectify` on a bag written by `rosbags`, checked against OpenCV.

The `rosbags` library writes a bag with three cameras, each with its camera_info:
/left (mono8, plumb_bob, stereo-rectified R and P), /right (rgb8, rational_polynomial)
and /fisheye (mono8, equidistant). `stereocal rectify` rectifies it (bilinear);
`rosbags` reads the output back and every `<ns>/image_rect` is compared with OpenCV's
`initUndistortRectifyMap` (`fisheye.initUndistortRectifyMap` for equidistant) + `remap`
(bilinear, constant border 0) on the same image and camera_info: at most 1 grey level
apart. Every input message must be copied unchanged and every frame rectified, and the
Python `mcap` library must read the same messages from the output file.

Usage: .venv/bin/python interop/check_rectify_bag_opencv.py [--width W --height H
       --frames N] [--uncompressed] [--bin path/to/stereocal]   (default: target/release/stereocal if
       built, else target/debug/stereocal)
"""

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np
from mcap.reader import make_reader
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_typestore

REPO = Path(__file__).resolve().parent.parent
ts = get_typestore(Stores.ROS2_HUMBLE)
T = ts.types


def rotation(rx, ry, rz):
    r, _ = cv2.Rodrigues(np.array([rx, ry, rz], dtype=np.float64))
    return r


def cameras(width, height):
    """(namespace, encoding, channels, distortion_model, D, K, R, P) per camera."""
    f = 0.8 * width
    k = np.array([[f, 0, (width - 1) / 2 + 3.2], [0, f * 1.01, (height - 1) / 2 - 2.1], [0, 0, 1]])
    p = np.array([[0.9 * f, 0, width / 2, 0], [0, 0.9 * f, height / 2, 0], [0, 0, 1, 0]])
    p_right = p.copy()
    p_right[0, 3] = -0.1 * 0.9 * f
    fish_k = np.array([[0.35 * width, 0, width / 2 - 0.5], [0, 0.35 * width, height / 2 - 0.5], [0, 0, 1]])
    fish_p = np.array([[0.21 * width, 0, width / 2 - 0.5, 0], [0, 0.21 * width, height / 2 - 0.5, 0],
                       [0, 0, 1, 0]])
    return [
        ('/left', 'mono8', 1, 'plumb_bob', [-0.28, 0.09, 0.0011, -0.0007, -0.012], k,
         rotation(0.004, -0.012, 0.002), p),
        ('/right', 'rgb8', 3, 'rational_polynomial',
         [-0.31, 0.11, -0.0009, 0.0004, 0.01, 0.05, 0.02, 0.004], k,
         rotation(0.003, 0.011, -0.002), p_right),
        ('/fisheye', 'mono8', 1, 'equidistant', [0.05, -0.01, 0.004, -0.001], fish_k,
         np.eye(3), fish_p),
    ]


def pattern(width, height, channels, frame, seed):
    """A checkerboard with texture, moving with the frame."""
    rng = np.random.default_rng(seed * 1000 + frame)
    y, x = np.mgrid[0:height, 0:width]
    board = (((x + 3 * frame) // 24 + y // 24) % 2) * 170 + 40
    img = board[..., None] + rng.integers(-30, 30, size=(height, width, channels))
    return np.clip(img, 0, 255).astype(np.uint8)


def header(frame, frame_id):
    return T['std_msgs/msg/Header'](
        stamp=T['builtin_interfaces/msg/Time'](sec=1000 + frame, nanosec=0), frame_id=frame_id)


def write_input(path, width, height, frames):
    expected = {}
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {}
        for ns, *_ in cameras(width, height):
            conns[ns] = (
                writer.add_connection(f'{ns}/image_raw', 'sensor_msgs/msg/Image', typestore=ts),
                writer.add_connection(f'{ns}/camera_info', 'sensor_msgs/msg/CameraInfo', typestore=ts),
            )
        for frame in range(frames):
            for index, (ns, encoding, channels, model, d, k, r, p) in enumerate(cameras(width, height)):
                img = pattern(width, height, channels, frame, index)
                t = (1000 + frame) * 1_000_000_000 + index * 1000
                info = T['sensor_msgs/msg/CameraInfo'](
                    header=header(frame, ns[1:]), height=height, width=width,
                    distortion_model=model, d=np.array(d, dtype=np.float64),
                    k=np.array(k, dtype=np.float64).ravel(), r=np.array(r, dtype=np.float64).ravel(),
                    p=np.array(p, dtype=np.float64).ravel(), binning_x=0, binning_y=0,
                    roi=T['sensor_msgs/msg/RegionOfInterest'](
                        x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
                msg = T['sensor_msgs/msg/Image'](
                    header=header(frame, ns[1:]), height=height, width=width, encoding=encoding,
                    is_bigendian=0, step=width * channels, data=img.reshape(-1))
                writer.write(conns[ns][1], t, ts.serialize_cdr(info, 'sensor_msgs/msg/CameraInfo'))
                writer.write(conns[ns][0], t + 10, ts.serialize_cdr(msg, 'sensor_msgs/msg/Image'))
                expected[(ns, frame)] = (img, model, np.array(d), k, r, p)
    return expected


def opencv_rectified(img, model, d, k, r, p, width, height):
    if model == 'equidistant':
        map1, map2 = cv2.fisheye.initUndistortRectifyMap(k, d, r, p[:, :3], (width, height), cv2.CV_16SC2)
    else:
        map1, map2 = cv2.initUndistortRectifyMap(k, d, r, p, (width, height), cv2.CV_16SC2)
    out = cv2.remap(img, map1, map2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return out.reshape(img.shape)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument('--width', type=int, default=320)
    parser.add_argument('--height', type=int, default=240)
    parser.add_argument('--frames', type=int, default=4)
    parser.add_argument('--uncompressed', action='store_true', help='pass --uncompressed to stereocal')
    parser.add_argument('--bin', type=Path)
    args = parser.parse_args()
    binary = args.bin
    if binary is None:
        release = REPO / 'target/release/stereocal'
        binary = release if release.exists() else REPO / 'target/debug/stereocal'
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        bag_in, bag_out = Path(tmp) / 'in', Path(tmp) / 'out'
        expected = write_input(bag_in, args.width, args.height, args.frames)
        command = [str(binary), 'rectify', '--bag', str(bag_in), '--out', str(bag_out)]
        if args.uncompressed:
            command.append('--uncompressed')
        run = subprocess.run(command, capture_output=True, text=True)
        print(run.stderr.strip())
        if run.returncode != 0:
            print(f'FAIL: stereocal rectify exited with {run.returncode}')
            return 1
        with Reader(bag_in) as reader:
            inputs = [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]
        worst = 0
        with Reader(bag_out) as reader:
            outputs = [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]
            types = {c.topic: c.msgtype for c in reader.connections}
        # The Python `mcap` library reads the same messages from the file (zstd chunks
        # compressed by several workers, or uncompressed).
        read_by_mcap = []
        for path in sorted(bag_out.glob('*.mcap')):
            with open(path, 'rb') as f:
                for _, channel, message in make_reader(f).iter_messages(log_time_order=True):
                    read_by_mcap.append((channel.topic, message.log_time, bytes(message.data)))
        if sorted(read_by_mcap) != sorted(outputs):
            failures.append('the mcap library reads other messages than rosbags')
        copies = [m for m in outputs if not m[0].endswith('/image_rect')]
        if sorted(copies) != sorted(inputs):
            failures.append('input messages are not all copied unchanged')
        rects = [m for m in outputs if m[0].endswith('/image_rect')]
        if len(rects) != len(expected):
            failures.append(f'{len(rects)} rectified images, expected {len(expected)}')
        for topic, _, raw in rects:
            if types[topic] != 'sensor_msgs/msg/Image':
                failures.append(f'{topic} has type {types[topic]}')
            msg = ts.deserialize_cdr(raw, 'sensor_msgs/msg/Image')
            ns = topic[: -len('/image_rect')]
            frame = msg.header.stamp.sec - 1000
            img, model, d, k, r, p = expected[(ns, frame)]
            got = np.frombuffer(msg.data, dtype=np.uint8).reshape(img.shape)
            ref = opencv_rectified(img, model, d, k, r, p, args.width, args.height)
            diff = int(np.abs(got.astype(int) - ref.astype(int)).max())
            worst = max(worst, diff)
            if diff > 1 or msg.encoding != ('rgb8' if ns == '/right' else 'mono8'):
                failures.append(f'{topic} frame {frame} ({model}): max |diff| {diff}, encoding {msg.encoding}')
        fps = re.search(r'\(([\d.]+) frames/s\)', run.stderr)
        print(f'{len(rects)} image_rect frames of {args.width}x{args.height}; max |stereocal - OpenCV| = '
              f'{worst} grey level(s); {fps.group(1) if fps else "?"} frames/s')
    for f in failures:
        print(f'FAIL: {f}')
    print('OK' if not failures else f'{len(failures)} failure(s)')
    return 1 if failures else 0


if __name__ == '__main__':
    sys.exit(main())
