"""Times `stereocal rectify` on a stereo bag against a Python script of OpenCV + rosbags
that does the same job, side by side in one run.

    .venv/bin/python interop/bench_rectify_bag_opencv.py [--bin PATH] [--frames 60]
        [--width 1024 --height 768] [--rounds 3] [--bag DIR]

The bag is `stereocal synth --scene stereo --rgb` (1024x768 rgb8 pairs with their
camera_info, zstd chunks) unless `--bag` names another. The script's side reads it with
`rosbags`, builds each camera's maps once (initUndistortRectifyMap, CV_16SC2), remaps every
image (bilinear, constant border, as image_proc), and writes every input message and each
`<ns>/image_rect` with `rosbags`' MCAP writer: once with zstd chunks
(`CompressionMode.STORAGE`, the same compression as stereocal's default output) and once
uncompressed (rosbags' default). stereocal runs `stereocal rectify` (zstd chunks) and
`stereocal rectify --uncompressed`. Rounds alternate between the sides, so that load from
other processes hits both alike. The script's times are its pipeline alone (after
`import cv2`), so its interpreter start does not count against it.

Prints, per configuration, the minimum and median wall times and stereocal's peak
resident memory (measured with GNU time, /usr/bin/time, when the machine has it), then the ratios (script time / stereocal time; above 1: stereocal is
faster) of the minima and the medians:

    zstd output:         stereocal rectify         against the script writing zstd chunks
    zstd vs plain:       stereocal rectify         against the script writing uncompressed
    uncompressed output: stereocal --uncompressed  against the script writing uncompressed

Each run's output is checked: as many image_rect messages as input images.

With `--bag` a large bag (for example 720 pairs, `stereocal synth --scene stereo --rgb
--frames 720`, 2.7 GB) and `--rounds 1` shows that memory stays bounded whatever the
bag's size.
"""

import argparse
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.typesys import Stores, get_typestore

REPO = Path(__file__).resolve().parent.parent
TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)
IMAGE = 'sensor_msgs/msg/Image'
CAMERA_INFO = 'sensor_msgs/msg/CameraInfo'
CHANNELS = {'mono8': 1, 'rgb8': 3, 'bgr8': 3}


def namespace(topic):
    return topic.rsplit('/', 1)[0]


def opencv_rectify_bag(bag_in, bag_out, compressed):
    """OpenCV + rosbags: every input message copied, each camera's images rectified into
    `<ns>/image_rect`. Returns the number of rectified images."""
    maps = {}
    infos = {}
    rectified = 0
    writer = Writer(bag_out, version=9, storage_plugin=StoragePlugin.MCAP)
    if compressed:
        writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with Reader(bag_in) as reader, writer:
        copies = {}
        rect = {}
        for c in reader.connections:
            copies[c.id] = writer.add_connection(c.topic, c.msgtype, typestore=TYPESTORE)
        for c in reader.connections:
            if c.msgtype == IMAGE and c.topic.endswith('/image_raw'):
                rect[c.id] = writer.add_connection(f'{namespace(c.topic)}/image_rect', IMAGE, typestore=TYPESTORE)
        pending = {}

        def rectify(connection, t, raw):
            ns = namespace(connection.topic)
            info = infos[ns]
            msg = TYPESTORE.deserialize_cdr(raw, IMAGE)
            if ns not in maps:
                k = info.k.reshape(3, 3)
                r = info.r.reshape(3, 3)
                p = info.p.reshape(3, 4)
                maps[ns] = cv2.initUndistortRectifyMap(k, info.d, r, p, (info.width, info.height), cv2.CV_16SC2)
            channels = CHANNELS[msg.encoding]
            img = np.frombuffer(msg.data, dtype=np.uint8).reshape(msg.height, msg.step)
            img = img[:, : msg.width * channels].reshape(msg.height, msg.width, channels)
            out = cv2.remap(img, maps[ns][0], maps[ns][1], cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_CONSTANT, borderValue=0)
            msg.data = np.ascontiguousarray(out).reshape(-1)
            msg.step = msg.width * channels
            writer.write(rect[connection.id], t, TYPESTORE.serialize_cdr(msg, IMAGE))

        for c, t, raw in reader.messages():
            writer.write(copies[c.id], t, raw)
            ns = namespace(c.topic)
            if c.msgtype == CAMERA_INFO:
                infos[ns] = TYPESTORE.deserialize_cdr(raw, CAMERA_INFO)
                # Images that came before their camera's first camera_info.
                for held in pending.pop(ns, []):
                    rectify(*held)
                    rectified += 1
            elif c.id in rect:
                if ns not in infos:
                    pending.setdefault(ns, []).append((c, t, raw))
                    continue
                rectify(c, t, raw)
                rectified += 1
    return rectified


def count_rect(bag):
    with Reader(bag) as reader:
        return sum(c.msgcount for c in reader.connections if c.topic.endswith('/image_rect'))


def run_stereocal(binary, bag_in, bag_out, uncompressed):
    """Wall time and peak resident memory (bytes, None without GNU time) of one
    `stereocal rectify`."""
    # Removed beforehand, as the script's output is: removing a large bag is no part of the job.
    shutil.rmtree(bag_out, ignore_errors=True)
    command = [str(binary), 'rectify', '--bag', str(bag_in), '--out', str(bag_out)]
    if uncompressed:
        command.append('--uncompressed')
    # GNU time reports the peak of stereocal alone; a child's own rusage would also
    # count the Python process it was forked from.
    timed = ['/usr/bin/time', '-f', 'peak-rss-kb %M'] if Path('/usr/bin/time').exists() else []
    start = time.perf_counter()
    run = subprocess.run(timed + command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    elapsed = time.perf_counter() - start
    if run.returncode != 0:
        raise SystemExit(f'stereocal rectify failed:\n{run.stderr}')
    peaks = [int(line.split()[1]) * 1024 for line in run.stderr.splitlines() if line.startswith('peak-rss-kb ')]
    return elapsed, peaks[-1] if peaks else None


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument('--bin', type=Path, default=REPO / 'target/release/stereocal')
    parser.add_argument('--bag', type=Path, help='input bag (default: a synthetic stereo bag)')
    parser.add_argument('--frames', type=int, default=60)
    parser.add_argument('--width', type=int, default=1024)
    parser.add_argument('--height', type=int, default=768)
    parser.add_argument('--rounds', type=int, default=3)
    args = parser.parse_args()
    cv2.setNumThreads(0)
    cv2.setNumThreads(-1)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        bag_in = args.bag
        if bag_in is None:
            subprocess.run([str(args.bin), 'synth', '--scene', 'stereo', '--rgb', '--out', str(tmp / 'scene'),
                            '--frames', str(args.frames), '--width', str(args.width), '--height',
                            str(args.height)], check=True, stdout=subprocess.DEVNULL)
            bag_in = tmp / 'scene' / 'bag'
        with Reader(bag_in) as reader:
            images = sum(c.msgcount for c in reader.connections
                         if c.msgtype == IMAGE and c.topic.endswith('/image_raw'))
            size = sum(f.stat().st_size for f in Path(bag_in).glob('*.mcap'))
        print(f'input: {bag_in} ({images} images, {size / 1e6:.0f} MB)')
        times = {k: [] for k in ('ours_zstd', 'ours_plain', 'cv_zstd', 'cv_plain')}
        rss = {'ours_zstd': None, 'ours_plain': None}
        for _ in range(args.rounds):
            for name, compressed in (('cv_zstd', True), ('cv_plain', False)):
                out = tmp / name
                shutil.rmtree(out, ignore_errors=True)
                start = time.perf_counter()
                done = opencv_rectify_bag(bag_in, out, compressed)
                times[name].append(time.perf_counter() - start)
                assert done == images, f'OpenCV script rectified {done} of {images} images'
            for name, uncompressed in (('ours_zstd', False), ('ours_plain', True)):
                out = tmp / name
                elapsed, peak = run_stereocal(args.bin, bag_in, out, uncompressed)
                times[name].append(elapsed)
                if peak is not None:
                    rss[name] = max(rss[name] or 0, peak)
                assert count_rect(out) == images, f'stereocal rectified {count_rect(out)} of {images} images'
        for name, values in times.items():
            extra = f', peak RSS {rss[name] / 1e6:.0f} MB' if rss.get(name) else ''
            print(f'{name:11s} min {min(values) * 1000:8.1f} ms  median {statistics.median(values) * 1000:8.1f} ms{extra}')
        for label, ours, theirs in (('zstd output', 'ours_zstd', 'cv_zstd'),
                                    ('zstd vs plain', 'ours_zstd', 'cv_plain'),
                                    ('uncompressed output', 'ours_plain', 'cv_plain')):
            ratio_min = min(times[theirs]) / min(times[ours])
            ratio_median = statistics.median(times[theirs]) / statistics.median(times[ours])
            print(f'{label:20s} OpenCV / stereocal: {ratio_min:.2f}x (minima), {ratio_median:.2f}x (medians)')


if __name__ == '__main__':
    main()
