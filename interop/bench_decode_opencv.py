#!/usr/bin/env python3
"""CompressedImage decoding speed, stereocal against OpenCV's imdecode, side by side.

The images: a 1920x1080 rendered-looking scene (a checkerboard with gradients, soft
shapes and sensor noise), encoded by OpenCV as JPEG (quality 90, colour and grey) and
PNG (grey). Each is decoded in batches of --calls calls, on one thread:
- stereocal: `decode_timing` (target/release/decode_timing), the decoding every node
  and command runs on a CompressedImage (`convert::image_msg_from_compressed`: JPEG by
  zune-jpeg, PNG by png), into the encoding the message's format names;
- OpenCV: cv2.imdecode (libjpeg-turbo, libpng) with cv2.setNumThreads(1), IMREAD_COLOR
  or IMREAD_GRAYSCALE.
A batch's time per call is taken; each side's time is the median over --repeats batches,
and --rounds rounds alternate the two sides so that a change of the machine's load
weighs on both; the medians over the rounds are compared. Prints per image the time per
call and the ratio OpenCV / stereocal (above 1, stereocal is faster).

Usage: .venv/bin/python interop/bench_decode_opencv.py
       [--tool target/release/decode_timing] [--calls 20] [--repeats 7] [--rounds 3]
"""

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
WIDTH, HEIGHT = 1920, 1080


def scene(seed=1):
    """A 1080p BGR image with the content of a camera view of a board."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH].astype(np.float32)
    board = ((x // 60 + y // 60) % 2) * 150 + 40
    light = 40 * np.sin(x / 300) * np.cos(y / 200)
    image = np.stack([board + light + c * 15 for c in range(3)], axis=-1)
    for _ in range(30):
        cx, cy, r = rng.uniform(0, WIDTH), rng.uniform(0, HEIGHT), rng.uniform(20, 150)
        image[(x - cx) ** 2 + (y - cy) ** 2 < r * r] += rng.uniform(-60, 60, 3)
    image = cv2.GaussianBlur(image, (5, 5), 1.2) + rng.normal(0, 2.0, image.shape)
    return np.clip(image, 0, 255).astype(np.uint8)


def opencv_time(data, flags, calls, repeats):
    buffer = np.frombuffer(data, np.uint8)
    batches = []
    for _ in range(repeats):
        started = time.perf_counter()
        for _ in range(calls):
            cv2.imdecode(buffer, flags)
        batches.append((time.perf_counter() - started) * 1e3 / calls)
    return statistics.median(batches)


def stereocal_time(tool, path, format, calls, repeats):
    out = subprocess.run([tool, str(path), format, str(calls), str(repeats)],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout)["median_ms"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tool", default=str(ROOT / "target" / "release" / "decode_timing"))
    parser.add_argument("--calls", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    if not Path(args.tool).exists():
        sys.exit(f"{args.tool} not found; build it with `cargo build --release --bin decode_timing`")
    cv2.setNumThreads(1)
    bgr = scene()
    grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    cases = [
        ("JPEG q90 bgr8", ".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, 90], cv2.IMREAD_COLOR,
         "bgr8; jpeg compressed bgr8"),
        ("JPEG q90 mono8", ".jpg", grey, [cv2.IMWRITE_JPEG_QUALITY, 90], cv2.IMREAD_GRAYSCALE,
         "mono8; jpeg compressed mono8"),
        ("PNG mono8", ".png", grey, [], cv2.IMREAD_GRAYSCALE, "mono8; png compressed"),
    ]
    print(f"decoding {WIDTH}x{HEIGHT}, one thread, OpenCV {cv2.__version__}; "
          f"{args.rounds} rounds of {args.repeats} batches of {args.calls} calls")
    print(f"{'image':16} {'bytes':>9} {'OpenCV ms':>10} {'stereocal ms':>13} {'OpenCV/ours':>12}")
    with tempfile.TemporaryDirectory() as tmp:
        for name, ext, image, params, flags, format in cases:
            ok, encoded = cv2.imencode(ext, image, params)
            if not ok:
                sys.exit(f"cv2.imencode {ext} failed")
            path = Path(tmp) / f"image{ext}"
            path.write_bytes(encoded.tobytes())
            ours, theirs = [], []
            for _ in range(args.rounds):
                theirs.append(opencv_time(encoded.tobytes(), flags, args.calls, args.repeats))
                ours.append(stereocal_time(args.tool, path, format, args.calls, args.repeats))
            o, t = statistics.median(ours), statistics.median(theirs)
            print(f"{name:16} {len(encoded):9d} {t:10.2f} {o:13.2f} {t / o:11.2f}x")


if __name__ == "__main__":
    main()
