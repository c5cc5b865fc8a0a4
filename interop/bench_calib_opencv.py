#!/usr/bin/env python3
"""Times stereocal's mono and stereo solves against cv2.calibrateCamera and
cv2.stereoCalibrate (CALIB_FIX_INTRINSIC) on the same corners, side by side in one run.

    .venv/bin/python interop/bench_calib_opencv.py [--iterations 50]

Both sides get exactly OpenCV's corners of the 13 real stereo pairs from
vision/tests/fixtures/opencv_calib_reference.json (made by opencv_calib_reference.py),
with OpenCV's default model (plumb_bob, five coefficients, every view kept). stereocal
runs through its criterion bench (`cargo bench -p stereocal-vision --bench calib`,
bencher output); OpenCV is timed here with time.perf_counter around each call. Prints
milliseconds per solve and the ratio OpenCV / stereocal (above 1: stereocal is faster).
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import time

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..")
FIXTURE = os.path.join(ROOT, "vision", "tests", "fixtures", "opencv_calib_reference.json")


def load():
    with open(FIXTURE) as f:
        fixture = json.load(f)
    obj = np.array(fixture["object_points"], dtype=np.float32)
    lefts = [np.array(p["left"], dtype=np.float32).reshape(-1, 1, 2) for p in fixture["pairs"]]
    rights = [np.array(p["right"], dtype=np.float32).reshape(-1, 1, 2) for p in fixture["pairs"]]
    return tuple(fixture["image_size"]), [obj] * len(lefts), lefts, rights


def time_calls(call, iterations):
    call()
    times = []
    for _ in range(iterations):
        start = time.perf_counter()
        call()
        times.append((time.perf_counter() - start) * 1e3)
    return min(times), statistics.median(times)


def time_opencv(iterations):
    size, obj, lefts, rights = load()
    mono = time_calls(lambda: cv2.calibrateCamera(obj, lefts, size, None, None), iterations)
    _, k1, d1, _, _ = cv2.calibrateCamera(obj, lefts, size, None, None)
    _, k2, d2, _, _ = cv2.calibrateCamera(obj, rights, size, None, None)
    stereo = time_calls(
        lambda: cv2.stereoCalibrate(obj, lefts, rights, k1, d1, k2, d2, size, flags=cv2.CALIB_FIX_INTRINSIC),
        iterations,
    )
    return {"mono": mono, "stereo": stereo}


def time_ours():
    out = subprocess.run(
        ["cargo", "bench", "-p", "stereocal-vision", "--bench", "calib", "--", "--output-format", "bencher"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    times = {}
    for name, ns in re.findall(r"test (\S+)\s+\.\.\. bench:\s+([\d,]+) ns/iter", out):
        times[name] = int(ns.replace(",", "")) / 1e6
    return times


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--iterations", type=int, default=50)
    args = parser.parse_args()
    ours = time_ours()
    opencv = time_opencv(args.iterations)
    print(f"OpenCV {cv2.__version__}, {cv2.getNumThreads()} threads; times in ms (OpenCV min / median)")
    rows = [
        ("mono, 13 views", opencv["mono"], ours["mono_left_13_views"]),
        ("mono with rejection", opencv["mono"], ours["mono_left_13_views_with_rejection"]),
        ("stereo, fixed intrinsics", opencv["stereo"], ours["stereo_fixed_intrinsics_13_pairs"]),
    ]
    for name, (cv_min, cv_median), mine in rows:
        print(
            f"{name:26} OpenCV {cv_min:8.3f} / {cv_median:8.3f}   stereocal {mine:8.3f}   "
            f"ratio {cv_median / mine:6.1f}x"
        )


if __name__ == "__main__":
    main()
