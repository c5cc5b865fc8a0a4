#!/usr/bin/env python3
"""OpenCV's corners and calibration results on the real stereo pairs, as a fixture.

Detects the 9x6 chessboard in the 13 pairs of ../shared/data/opencv-stereo with OpenCV's
default pipeline (findChessboardCorners, then cornerSubPix with winSize (5, 5), criteria
EPS|MAX_ITER 30/0.01), calibrates each camera with calibrateCameraExtended (default
5-coefficient plumb_bob model, no flags) and the pair with stereoCalibrate
(CALIB_FIX_INTRINSIC), and writes corners and results to
vision/tests/fixtures/opencv_calib_reference.json. vision/tests/calib_opencv.rs feeds
exactly these corners to stereocal's solvers and compares the results.

Object points are the board's inner corners in the target frame, row by row as OpenCV
orders them: (col * square, row * square, 0), square 1.0.

Run with the project's virtual environment:
    .venv/bin/python interop/opencv_calib_reference.py [--data DIR]
"""

import argparse
import json
import os
import tempfile

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "vision", "tests", "fixtures", "opencv_calib_reference.json")
DATA = os.path.join(HERE, "..", "..", "shared", "data", "opencv-stereo")
COLS, ROWS, SQUARE = 9, 6, 1.0
CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01)


def object_points():
    return np.array(
        [[c * SQUARE, r * SQUARE, 0.0] for r in range(ROWS) for c in range(COLS)], dtype=np.float32
    )


def detect(path):
    gray = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    if gray is None:
        raise SystemExit(f"cannot read {path}")
    found, corners = cv2.findChessboardCorners(gray, (COLS, ROWS))
    if not found:
        return gray.shape[::-1], None
    corners = cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1), CRITERIA)
    return gray.shape[::-1], corners


def detect_pairs(data):
    """Corners of every pair detected in both images, with the image size."""
    names = sorted(
        f[len("left") : -len(".jpg")] for f in os.listdir(data) if f.startswith("left") and f.endswith(".jpg")
    )
    pairs, size = [], None
    for name in names:
        size, left = detect(os.path.join(data, f"left{name}.jpg"))
        _, right = detect(os.path.join(data, f"right{name}.jpg"))
        if left is not None and right is not None:
            pairs.append((name, left, right))
    return size, pairs


def mono(size, corners):
    obj = [object_points()] * len(corners)
    rms, k, d, rvecs, tvecs, std_intrinsics, _, per_view = cv2.calibrateCameraExtended(
        obj, corners, size, None, None
    )
    return {
        "rms": rms,
        "k": k.reshape(-1).tolist(),
        "d": d.reshape(-1).tolist(),
        "std_intrinsics": std_intrinsics.reshape(-1)[:9].tolist(),
        "per_view_rms": per_view.reshape(-1).tolist(),
        "rvecs": [r.reshape(-1).tolist() for r in rvecs],
        "tvecs": [t.reshape(-1).tolist() for t in tvecs],
    }


def stereo(size, lefts, rights, left, right):
    obj = [object_points()] * len(lefts)
    k1, d1 = np.array(left["k"]).reshape(3, 3), np.array(left["d"])
    k2, d2 = np.array(right["k"]).reshape(3, 3), np.array(right["d"])
    rms, _, _, _, _, r, t, e, f = cv2.stereoCalibrate(
        obj, lefts, rights, k1, d1, k2, d2, size, flags=cv2.CALIB_FIX_INTRINSIC
    )
    return {
        "rms": rms,
        "rotation": r.reshape(-1).tolist(),
        "translation": t.reshape(-1).tolist(),
        "essential": e.reshape(-1).tolist(),
        "fundamental": f.reshape(-1).tolist(),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default=DATA, help="directory of leftNN.jpg / rightNN.jpg")
    args = parser.parse_args()
    size, pairs = detect_pairs(args.data)
    lefts = [p[1] for p in pairs]
    rights = [p[2] for p in pairs]
    left, right = mono(size, lefts), mono(size, rights)
    fixture = {
        "source": "interop/opencv_calib_reference.py on ../shared/data/opencv-stereo",
        "opencv_version": cv2.__version__,
        "board": {"cols": COLS, "rows": ROWS, "square": SQUARE},
        "image_size": list(size),
        "object_points": object_points().astype(float).tolist(),
        "pairs": [
            {"name": name, "left": l.reshape(-1, 2).astype(float).tolist(), "right": r.reshape(-1, 2).astype(float).tolist()}
            for name, l, r in pairs
        ],
        "left": left,
        "right": right,
        "stereo": stereo(size, lefts, rights, left, right),
    }
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(OUT), suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        json.dump(fixture, f, indent=1)
        f.write("\n")
    os.replace(tmp, OUT)
    print(
        f"{len(pairs)} pairs; left RMS {left['rms']:.4f}, right RMS {right['rms']:.4f}, "
        f"stereo RMS {fixture['stereo']['rms']:.4f}, |T| {np.linalg.norm(fixture['stereo']['translation']):.4f}"
    )


if __name__ == "__main__":
    main()
