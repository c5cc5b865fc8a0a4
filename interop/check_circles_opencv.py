"""stereocal's circle grids against OpenCV's findCirclesGrid + calibrateCamera and the truth.

For each lens model (plumb_bob, rational_polynomial, equidistant) and each circle grid
(config/boards/acircles_4x11_20mm.yaml, circles_9x6_40mm.yaml), `stereocal synth
--scene calibration --board ...` renders a 1280x720 stereo session (views tilted up to
40 degrees about each board axis, one frame in ten blurred, moving or partly out of
view) with its ground truth. On the same images:

- detection: stereocal (the `detect_target` example, one thread) against
  cv2.findCirclesGrid (default blob detector, cv2.setNumThreads(1)); centre errors
  against the true projected centres on clean frames (median), and the median time
  per image over the images both found the grid in (decoding not timed);
- calibration: `stereocal calibrate --pattern circles|acircles --json` against
  cv2.calibrateCamera (cv2.fisheye.calibrate for equidistant; CALIB_RATIONAL_MODEL for
  rational_polynomial) on OpenCV's centres, per camera; the largest error of fx, fy,
  cx, cy against the truth, per camera and over the bag's two cameras.

Exits non-zero when a stereocal intrinsic is 0.2 px or more from the truth, when the
largest intrinsics error over a bag's cameras is not below OpenCV's, when its median
centre error on clean frames is above 0.03 px, or when it misses a clean frame OpenCV
finds.

Usage: .venv/bin/python interop/check_circles_opencv.py [--frames N] [--repeats N]
       [--bin path/to/stereocal] [--detect path/to/detect_target]
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
TOPICS = {"/stereo/left/image_raw": "left", "/stereo/right/image_raw": "right"}
BOARDS = {
    "acircles": REPO / "config/boards/acircles_4x11_20mm.yaml",
    "circles": REPO / "config/boards/circles_9x6_40mm.yaml",
}
MODELS = ("plumb_bob", "rational_polynomial", "equidistant")


def built(path):
    release = REPO / "target" / "release" / path
    return release if release.exists() else REPO / "target" / "debug" / path


def object_points(pattern, cols, rows, spacing):
    """OpenCV's object points of a circle grid (the calibration.cpp sample's)."""
    points = []
    for i in range(rows):
        for j in range(cols):
            x = (2 * j + i % 2) if pattern == "acircles" else j
            points.append((x * spacing, i * spacing, 0.0))
    return np.array(points, np.float32)


def opencv_find(img, pattern, cols, rows, repeats):
    flags = cv2.CALIB_CB_ASYMMETRIC_GRID if pattern == "acircles" else cv2.CALIB_CB_SYMMETRIC_GRID
    times, found = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        ok, centres = cv2.findCirclesGrid(img, (cols, rows), flags=flags)
        times.append(time.perf_counter() - start)
        found = centres.reshape(-1, 2) if ok else None
    return found, float(np.median(times))


def opencv_calibrate(views, model, size):
    """K of cv2.calibrateCamera (or cv2.fisheye.calibrate) on (object, image) views."""
    objects = [o for o, _ in views]
    images = [i.astype(np.float32) for _, i in views]
    if model == "equidistant":
        flags = cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW
        criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-10)
        _, k, _, _, _ = cv2.fisheye.calibrate(
            [o.reshape(-1, 1, 3).astype(np.float64) for o in objects],
            [i.reshape(-1, 1, 2).astype(np.float64) for i in images],
            size, None, None, flags=flags, criteria=criteria,
        )
        return k
    flags = cv2.CALIB_RATIONAL_MODEL if model == "rational_polynomial" else 0
    _, k, _, _, _ = cv2.calibrateCamera(objects, images, size, None, None, flags=flags)
    return k


def k_error(k, truth_k):
    return max(abs(k[0][0] - truth_k[0][0]), abs(k[1][1] - truth_k[1][1]),
               abs(k[0][2] - truth_k[0][2]), abs(k[1][2] - truth_k[1][2]))


def session(args, tmp, pattern, model, seed, failures):
    board = BOARDS[pattern]
    text = dict(line.split(":", 1) for line in board.read_text().splitlines()
                if ":" in line and not line.startswith("#"))
    cols, rows, spacing = int(text["cols"]), int(text["rows"]), float(text["spacing"])
    out = tmp / f"{pattern}_{model}"
    subprocess.run(
        [str(args.bin), "synth", "--scene", "calibration", "--board", str(board), "--model", model,
         "--width", "1280", "--height", "720", "--frames", str(args.frames), "--seed", str(seed),
         "--out", str(out)],
        check=True, stderr=subprocess.DEVNULL,
    )
    truth = json.loads((out / "ground_truth.json").read_text())
    images = {(TOPICS[t], s): img for t, s, img in grey_images(out / "bag", TOPICS)}
    paths = {}
    for (camera, stamp), img in images.items():
        path = tmp / f"{pattern}_{model}_{camera}_{stamp[0]}_{stamp[1]:09d}.png"
        cv2.imwrite(str(path), img)
        paths[(camera, stamp)] = path
    run = subprocess.run(
        [str(args.detect), "--repeats", str(args.repeats), str(board), *map(str, paths.values())],
        check=True, capture_output=True, text=True,
    )
    ours = {}
    for line in run.stdout.splitlines():
        record = json.loads(line)
        ours[record["image"]] = record
    where = f"{pattern} {model}"
    errors = {"stereocal": [], "opencv": []}
    times = {"stereocal": [], "opencv": []}
    views = {"left": [], "right": []}
    objects = object_points(pattern, cols, rows, spacing)
    for frame in truth["frames"]:
        stamp = (frame["stamp"]["sec"], frame["stamp"]["nanosec"])
        for view in frame["views"]:
            key = (view["camera"], stamp)
            truth_px = np.array([c["pixel"] if c["visible"] else [np.nan, np.nan] for c in view["corners"]])
            mine = ours[str(paths[key])]
            theirs, cv_seconds = opencv_find(images[key], pattern, cols, rows, args.repeats)
            if theirs is not None:
                views[view["camera"]].append((objects, theirs))
            if mine["ids"] is not None and theirs is not None:
                times["stereocal"].append(mine["seconds"])
                times["opencv"].append(cv_seconds)
            if frame["kind"] != "clean":
                continue
            if mine["ids"] is None:
                if theirs is not None:
                    failures.append(f"{where} frame {frame['index']} {view['camera']}: OpenCV finds the grid, stereocal does not")
                continue
            errors["stereocal"].extend(np.hypot(*(np.array(mine["corners"]) - truth_px).T))
            if theirs is not None:
                # OpenCV may number a symmetric grid from either end: take the nearer.
                direct = np.hypot(*(theirs - truth_px).T)
                turned = np.hypot(*(theirs[::-1] - truth_px).T)
                errors["opencv"].extend(direct if np.nanmean(direct) < np.nanmean(turned) else turned)
    run = subprocess.run(
        [str(args.bin), "calibrate", "--bag", str(out / "bag"), "--out", str(out / "calibration"),
         "--pattern", pattern, "--size", f"{cols}x{rows}", "--square", str(spacing),
         "--model", model, "--json"],
        capture_output=True, text=True,
    )
    if run.returncode != 0:
        failures.append(f"{where}: stereocal calibrate failed: {run.stderr.strip()}")
        return None
    calibrated = json.loads(run.stdout)
    rows_out = []
    for record in truth["cameras"]:
        name = record["name"]
        truth_k = np.array(record["camera_matrix_row_major"]).reshape(3, 3)
        ours_k = np.array(calibrated["cameras"][name]["k"]).reshape(3, 3)
        cv_k = opencv_calibrate(views[name], model, (1280, 720))
        ours_error, cv_error = k_error(ours_k, truth_k), k_error(cv_k, truth_k)
        rows_out.append((name, ours_error, cv_error, len(views[name])))
        if ours_error >= 0.2:
            failures.append(f"{where} {name}: an intrinsic {ours_error:.3f} px from the truth")
    ours_worst = max(r[1] for r in rows_out)
    cv_worst = max(r[2] for r in rows_out)
    if ours_worst >= cv_worst:
        failures.append(f"{where}: largest intrinsics error {ours_worst:.3f} px, OpenCV's {cv_worst:.3f} px")
    median_ours = float(np.nanmedian(errors["stereocal"]))
    median_cv = float(np.nanmedian(errors["opencv"])) if errors["opencv"] else float("nan")
    if median_ours > 0.03:
        failures.append(f"{where}: median centre error {median_ours:.4f} px on clean frames")
    speed = np.median(times["opencv"]) / np.median(times["stereocal"]) if times["stereocal"] else float("nan")
    for name, ours_error, cv_error, used in rows_out:
        print(f"| {pattern} | {model} | {name} | {ours_error:.3f} | {cv_error:.3f} ({used} views) "
              f"| {median_ours:.4f} | {median_cv:.4f} | {speed:.2f}x |")
    print(f"| {pattern} | {model} | largest of the two | {ours_worst:.3f} | {cv_worst:.3f} | | | |")
    return speed


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--bin", type=Path, default=built("stereocal"))
    parser.add_argument("--detect", type=Path, default=built("examples/detect_target"))
    args = parser.parse_args()
    cv2.setNumThreads(1)
    failures = []
    speeds = []
    print("| grid | model | camera | stereocal: largest intrinsics error (px) | OpenCV | "
          "stereocal: median centre error (px) | OpenCV | detection speed (OpenCV time / ours) |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for seed, (pattern, model) in enumerate(((p, m) for p in BOARDS for m in MODELS), start=80):
            speed = session(args, Path(tmp), pattern, model, seed, failures)
            if speed is not None:
                speeds.append(speed)
    print(f"detection speed, median of the sessions: {np.median(speeds):.2f}x OpenCV")
    for failure in failures:
        print("MISMATCH:", failure)
    if failures:
        sys.exit(1)
    print("circle grids agree with the truth and beat OpenCV")


if __name__ == "__main__":
    main()
