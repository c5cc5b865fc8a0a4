"""`stereocal calibrate` against ground truth, side by side with OpenCV's default pipeline.

`stereocal synth --scene calibration` writes a stereo calibration session (about one
frame in ten blurred, moving or partly out of view) with its ground truth. The session
is calibrated twice:
- `stereocal calibrate --json`;
- OpenCV, as its tutorials do: `findChessboardCorners` + `cornerSubPix` (11x11 window)
  on every frame, `calibrateCamera` per camera on the frames where the board was found,
  `stereoCalibrate` (CALIB_FIX_INTRINSIC) on the frames found in both cameras
  (CALIB_RATIONAL_MODEL for rational_polynomial; `cv2.fisheye.calibrate` and
  `cv2.fisheye.stereoCalibrate` for equidistant).
Both are compared with the truth: fx, fy, cx, cy errors, and right_from_left rotation
(degrees) and translation (mm) errors. Exits non-zero when stereocal misses the
acceptance bar (0.2 px, 0.05 degrees, 0.3 mm).

Usage: .venv/bin/python interop/check_calibrate_opencv.py [--frames N] [--seed S]
       [--width W --height H]
       [--model plumb_bob|rational_polynomial|equidistant] [--bin path/to/stereocal]
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from bag_images import grey_images

REPO = Path(__file__).resolve().parent.parent
TOPICS = ("/stereo/left/image_raw", "/stereo/right/image_raw")


def default_binary():
    release = REPO / "target" / "release" / "stereocal"
    return release if release.exists() else REPO / "target" / "debug" / "stereocal"


def read_images(bag):
    """{topic: {(sec, nanosec): grey image}}."""
    images = {t: {} for t in TOPICS}
    for topic, stamp, img in grey_images(bag, TOPICS):
        images[topic][stamp] = img
    return images


def opencv_calibrate(images, cols, rows, square, model):
    objp = np.zeros((cols * rows, 3), np.float32)
    objp[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
    corners = {}
    size = None
    for topic in TOPICS:
        corners[topic] = {}
        for stamp, img in images[topic].items():
            size = (img.shape[1], img.shape[0])
            found, c = cv2.findChessboardCorners(img, (cols, rows), None)
            if found:
                corners[topic][stamp] = cv2.cornerSubPix(img, c, (11, 11), (-1, -1), criteria)
    fisheye = model == "equidistant"
    flags = cv2.CALIB_RATIONAL_MODEL if model == "rational_polynomial" else 0
    fisheye_objp = objp.reshape(-1, 1, 3).astype(np.float64)
    results = {}
    for topic in TOPICS:
        views = list(corners[topic].values())
        if fisheye:
            rms, k, d, _, _ = cv2.fisheye.calibrate(
                [fisheye_objp] * len(views), [v.astype(np.float64) for v in views], size,
                None, None, flags=cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW,
            )
        else:
            rms, k, d, _, _ = cv2.calibrateCamera(
                [objp] * len(views), views, size, None, None, flags=flags
            )
        results[topic] = (rms, k, d, len(views))
    common = sorted(set(corners[TOPICS[0]]) & set(corners[TOPICS[1]]))
    (_, k1, d1, _), (_, k2, d2, _) = results[TOPICS[0]], results[TOPICS[1]]
    left = [corners[TOPICS[0]][s] for s in common]
    right = [corners[TOPICS[1]][s] for s in common]
    if fisheye:
        rms, *_, r, t = cv2.fisheye.stereoCalibrate(
            [fisheye_objp] * len(common),
            [v.astype(np.float64) for v in left], [v.astype(np.float64) for v in right],
            k1, d1, k2, d2, size, flags=cv2.fisheye.CALIB_FIX_INTRINSIC,
        )[:7]
    else:
        rms, *_, r, t, _, _ = cv2.stereoCalibrate(
            [objp] * len(common), left, right, k1, d1, k2, d2, size,
            flags=cv2.CALIB_FIX_INTRINSIC,
        )
    return results, (rms, r, np.asarray(t).ravel(), len(common))


def rotation_error_degrees(r, r_true):
    angle, _ = cv2.Rodrigues(r @ r_true.T)
    return float(np.degrees(np.linalg.norm(angle)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=25)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--model", default="plumb_bob")
    parser.add_argument("--width", type=int, default=1024)
    parser.add_argument("--height", type=int, default=768)
    parser.add_argument("--bin", type=Path, default=default_binary())
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        subprocess.run(
            [args.bin, "synth", "--scene", "calibration", "--out", tmp / "session",
             "--frames", str(args.frames), "--seed", str(args.seed), "--model", args.model,
             "--width", str(args.width), "--height", str(args.height)],
            check=True, stderr=subprocess.DEVNULL,
        )
        truth = json.loads((tmp / "session" / "ground_truth.json").read_text())
        board = truth["board"]
        cols, rows, square = board["inner_corners_cols"], board["inner_corners_rows"], board["square_size_m"]
        started = time.perf_counter()
        run = subprocess.run(
            [args.bin, "calibrate", "--bag", tmp / "session" / "bag", "--out", tmp / "out",
             "--size", f"{cols}x{rows}", "--square", str(square), "--model", args.model, "--json"],
            capture_output=True, text=True,
        )
        if run.returncode != 0:
            print(f"stereocal calibrate failed:\n{run.stderr}", file=sys.stderr)
            sys.exit(1)
        ours = json.loads(run.stdout)
        ours_seconds = time.perf_counter() - started
        started = time.perf_counter()
        images = read_images(tmp / "session" / "bag")
        cv_cameras, cv_stereo = opencv_calibrate(images, cols, rows, square, args.model)
        cv_seconds = time.perf_counter() - started

    bad = [f["index"] for f in truth["frames"] if f["kind"] != "clean"]
    print(f"{args.frames} frames of {args.width}x{args.height}, model {args.model}, bad frames {bad}")
    ok = True
    for record, topic in zip(truth["cameras"], TOPICS):
        k_true = np.array(record["camera_matrix_row_major"]).reshape(3, 3)
        k_ours = np.array(ours["cameras"][record["name"]]["k"]).reshape(3, 3)
        rms_cv, k_cv, _, views_cv = cv_cameras[topic]
        for label, k, rms, views in (
            ("stereocal", k_ours, ours["cameras"][record["name"]]["rms"],
             ours["cameras"][record["name"]]["views_used"]),
            ("opencv   ", k_cv, rms_cv, views_cv),
        ):
            errors = [k[0, 0] - k_true[0, 0], k[1, 1] - k_true[1, 1],
                      k[0, 2] - k_true[0, 2], k[1, 2] - k_true[1, 2]]
            print(f"{record['name']:5} {label} rms {rms:.4f} px, {views:2} views, "
                  "fx fy cx cy error " + " ".join(f"{e:+.3f}" for e in errors) + " px")
            if label == "stereocal" and max(abs(e) for e in errors) >= 0.2:
                ok = False
    rt = truth["extrinsics"]["right_from_left"]
    r_true = np.array(rt["rotation_row_major"]).reshape(3, 3)
    t_true = np.array(rt["translation_m"])
    r_ours = np.array(ours["stereo"]["right_from_left"]["rotation"]).reshape(3, 3)
    t_ours = np.array(ours["stereo"]["right_from_left"]["translation"])
    rms_cv, r_cv, t_cv, pairs_cv = cv_stereo
    for label, rms, r, t in (
        ("stereocal", ours["stereo"]["rms"], r_ours, t_ours),
        ("opencv   ", rms_cv, r_cv, t_cv),
    ):
        angle = rotation_error_degrees(r, r_true)
        offset = np.linalg.norm(t - t_true) * 1e3
        print(f"stereo {label} rms {rms:.4f} px, right_from_left error {angle:.4f} deg, {offset:.4f} mm")
        if label == "stereocal" and (angle >= 0.05 or offset >= 0.3):
            ok = False
    print(f"wall time: stereocal calibrate {ours_seconds:.2f} s, OpenCV (read + detect + calibrate) {cv_seconds:.2f} s")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
