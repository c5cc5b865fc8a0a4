#!/usr/bin/env python3
"""Chessboard detection speed, ours against OpenCV's, on the same 1280x720 frames in
one run.

Runs the criterion bench vision/benches/detect.rs (which renders eight synthetic
frames of a 9x6 board, writes them to target/detect_bench/*.png and times our
detection on them), then times OpenCV's findChessboardCorners (default flags) +
cornerSubPix (winSize (5, 5), EPS|MAX_ITER 30/0.01) on those PNGs, and prints the
time per frame of each and their ratio.

Usage: .venv/bin/python interop/bench_detect_opencv.py [--skip-cargo]
"""

import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import cv2

ROOT = Path(__file__).resolve().parent.parent
FRAMES = ROOT / "target/detect_bench"
ESTIMATES = ROOT / "target/criterion/detect_chessboard_1280x720/frames/new/estimates.json"
CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01)


def opencv_seconds_per_frame(images, repeats=10):
    """Median over repeats of the mean time per frame, one thread as our bench."""
    runs = []
    for _ in range(repeats):
        start = time.perf_counter()
        for gray in images:
            found, corners = cv2.findChessboardCorners(gray, (9, 6))
            if not found:
                raise SystemExit("OpenCV missed a frame")
            cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1), CRITERIA)
        runs.append((time.perf_counter() - start) / len(images))
    return statistics.median(runs)


def main() -> int:
    if "--skip-cargo" not in sys.argv:
        subprocess.run(
            ["cargo", "bench", "-p", "stereocal-vision", "--bench", "detect", "--", "--noplot"],
            cwd=ROOT,
            check=True,
        )
    paths = sorted(FRAMES.glob("frame*.png"))
    if not paths:
        print(f"no frames in {FRAMES}: run the bench first", file=sys.stderr)
        return 1
    images = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in paths]
    ours = json.loads(ESTIMATES.read_text())["mean"]["point_estimate"] * 1e-9 / len(paths)
    cv2.setNumThreads(1)
    theirs_1 = opencv_seconds_per_frame(images)
    cv2.setNumThreads(0)
    theirs_n = opencv_seconds_per_frame(images)
    print(f"frames: {len(paths)} of {images[0].shape[1]}x{images[0].shape[0]}")
    print(f"stereocal (criterion mean):                {ours * 1e3:8.2f} ms/frame")
    print(f"OpenCV {cv2.__version__} findChessboardCorners+cornerSubPix, 1 thread:  "
          f"{theirs_1 * 1e3:8.2f} ms/frame  (ours / OpenCV = {ours / theirs_1:.2f})")
    print(f"OpenCV {cv2.__version__} findChessboardCorners+cornerSubPix, default threads: "
          f"{theirs_n * 1e3:8.2f} ms/frame  (ours / OpenCV = {ours / theirs_n:.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
