#!/usr/bin/env python3
"""Uncalibrated rectification, stereocal against OpenCV's `stereoRectifyUncalibrated`.

1. Homographies on the same points. Seeded problems (--problems): two distortion-free
   1024x768 pinhole cameras of different lenses on a rig turned 2 to 8 degrees towards
   each other, rolled and pitched up to 2 degrees, 8 to 20 cm apart (the second camera
   on either side, so both orientations of the epipole occur); --points scene points 1.5
   to 8 m away, 0.3 px Gaussian noise on every coordinate, 10 % of the right points
   moved 10 to 40 px off their epipolar line. OpenCV's findFundamentalMat (FM_RANSAC,
   1 px, 0.999) gives F; both implementations get the same points, F, image size and
   threshold (--thresholds). Asserted: the same correspondences are kept (OpenCV's rule,
   recomputed here with computeCorrespondEpilines); every kept point's rectified row
   agrees between ours and OpenCV's within 0.1 px in each image.

2. A rendered pair. `stereocal synth --scene stereo` renders a chessboard session with
   lens distortion; OpenCV turns it into a distortion-free verged pair
   (initUndistortRectifyMap with the true K and D, each camera turned 3 degrees towards
   the other, the right one also rolled 1.5 degrees, then remap) and `rosbags` writes it
   as /cam/left/image_raw and /cam/right/image_raw. `stereocal rectify --uncalibrated
   --pattern chessboard --size 9x6 --square 0.04` rectifies it; `rosbags` reads
   /cam/{left,right}/image_rect back and OpenCV finds the corners in both rectified
   images (findChessboardCorners + cornerSubPix, findChessboardCornersSB where that finds
   none). Asserted: the board is found in every rectified pair where it is found in both
   verged images, and on every clean frame each corner's rows agree within 0.5 px.
   Printed beside it: OpenCV's own pipeline on the same pair (its corners,
   findFundamentalMat, stereoRectifyUncalibrated, warpPerspective) measured the same way.

Usage: .venv/bin/python interop/check_rectify_uncalibrated_opencv.py
       [--example target/release/examples/rectify_uncalibrated]
       [--bin target/release/stereocal] [--problems 8] [--points 300] [--seed 1]
       [--thresholds 2 5] [--frames 6]
"""

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np
import yaml
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_typestore

REPO = Path(__file__).resolve().parent.parent
WIDTH, HEIGHT = 1024, 768
BOARD = (9, 6)
ROW_AGREEMENT_PX = 0.1
ROW_ALIGNMENT_PX = 0.5
ts = get_typestore(Stores.ROS2_HUMBLE)
T = ts.types


def rotation(rx, ry, rz):
    return cv2.Rodrigues(np.array([rx, ry, rz], dtype=np.float64))[0]


def project(k, points):
    p = points @ k.T
    return p[:, :2] / p[:, 2:]


def problem(rng, index, count):
    """Matched pixels of a verged rig with noise and outliers, and which are outliers."""
    k1 = np.array([[rng.uniform(700, 900), 0, rng.uniform(490, 530)],
                   [0, 0, rng.uniform(365, 400)], [0, 0, 1]])
    k1[1, 1] = k1[0, 0] * rng.uniform(0.995, 1.005)
    k2 = k1.copy()
    k2[0, 0] *= rng.uniform(0.9, 1.1)
    k2[1, 1] = k2[0, 0] * rng.uniform(0.995, 1.005)
    k2[:2, 2] += rng.uniform(-15, 15, size=2)
    side = 1.0 if index % 2 == 0 else -1.0
    verge = np.radians(rng.uniform(2, 8)) * side
    r = rotation(np.radians(rng.uniform(-2, 2)), -verge, np.radians(rng.uniform(-2, 2)))
    centre = np.array([side * rng.uniform(0.08, 0.2), rng.uniform(-0.01, 0.01), rng.uniform(-0.02, 0.02)])
    t = -r @ centre
    left, right = [], []
    while len(left) < count:
        z = rng.uniform(1.5, 8.0)
        x = np.array([rng.uniform(-0.6, 0.6) * z, rng.uniform(-0.45, 0.45) * z, z])
        a = project(k1, x[None])[0]
        b = project(k2, (r @ x + t)[None])[0]
        inside = lambda p: 0 <= p[0] <= WIDTH - 1 and 0 <= p[1] <= HEIGHT - 1
        if (r @ x + t)[2] > 0 and inside(a) and inside(b):
            left.append(a)
            right.append(b)
    left = np.array(left) + rng.normal(0, 0.3, size=(count, 2))
    right = np.array(right) + rng.normal(0, 0.3, size=(count, 2))
    outliers = rng.random(count) < 0.1
    # Off the epipolar line: along the line's normal, by 10 to 40 px either way.
    f_true = np.linalg.inv(k2).T @ np.cross(np.eye(3), t) @ r @ np.linalg.inv(k1)
    for i in np.flatnonzero(outliers):
        line = f_true @ np.array([*left[i], 1.0])
        normal = line[:2] / np.linalg.norm(line[:2])
        right[i] += normal * rng.uniform(10, 40) * rng.choice([-1, 1])
    return left, right, outliers


def opencv_kept(left, right, f, threshold):
    """OpenCV's rule: both points within `threshold` of the other one's epipolar line."""
    lines_in_right = cv2.computeCorrespondEpilines(left.reshape(-1, 1, 2), 1, f).reshape(-1, 3)
    lines_in_left = cv2.computeCorrespondEpilines(right.reshape(-1, 1, 2), 2, f).reshape(-1, 3)
    d_left = np.abs(np.sum(lines_in_left[:, :2] * left, axis=1) + lines_in_left[:, 2])
    d_right = np.abs(np.sum(lines_in_right[:, :2] * right, axis=1) + lines_in_right[:, 2])
    return (d_left <= threshold) & (d_right <= threshold)


def apply(h, points):
    p = np.c_[points, np.ones(len(points))] @ h.T
    return p[:, :2] / p[:, 2:]


def check_homographies(args, failures):
    rng = np.random.default_rng(args.seed)
    problems, inputs = [], {}
    for index in range(args.problems):
        left, right, outliers = problem(rng, index, args.points)
        f, _ = cv2.findFundamentalMat(left, right, cv2.FM_RANSAC, 1.0, 0.999)
        for threshold in args.thresholds:
            name = f"problem {index} threshold {threshold:g}"
            inputs[name] = (left, right, f, threshold, outliers)
            problems.append({"name": name, "width": WIDTH, "height": HEIGHT, "threshold": threshold,
                             "points_left": left.tolist(), "points_right": right.tolist(),
                             "fundamental": f.ravel().tolist()})
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "problems.json"
        path.write_text(json.dumps({"problems": problems}))
        done = subprocess.run([str(args.example), str(path)], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"rectify_uncalibrated failed:\n{done.stderr}")
    ours = {p["name"]: p for p in json.loads(done.stdout)["problems"]}

    worst = 0.0
    worst_matrix = 0.0
    print(f"homographies on the same points ({args.problems} rigs x {len(args.thresholds)} thresholds, "
          f"{args.points} points, 0.3 px noise, 10 % outliers):")
    for name, (left, right, f, threshold, outliers) in inputs.items():
        result = ours[name]
        if "error" in result:
            failures.append(f"{name}: ours refused: {result['error']}")
            continue
        ok, h1, h2 = cv2.stereoRectifyUncalibrated(left, right, f, (WIDTH, HEIGHT), threshold=threshold)
        if not ok:
            failures.append(f"{name}: OpenCV found no rectification")
            continue
        kept = opencv_kept(left, right, f, threshold)
        our_kept = np.array(result["inliers"], dtype=bool)
        if not np.array_equal(kept, our_kept):
            failures.append(f"{name}: kept {int(our_kept.sum())} correspondences, OpenCV {int(kept.sum())} "
                            f"({int((kept != our_kept).sum())} differ)")
        our_h1 = np.array(result["rectified_left_from_image_left"]).reshape(3, 3)
        our_h2 = np.array(result["rectified_right_from_image_right"]).reshape(3, 3)
        rows = max(np.abs(apply(our_h1, left[kept])[:, 1] - apply(h1, left[kept])[:, 1]).max(),
                   np.abs(apply(our_h2, right[kept])[:, 1] - apply(h2, right[kept])[:, 1]).max())
        matrix = max(np.linalg.norm(our_h1 - h1) / np.linalg.norm(h1),
                     np.linalg.norm(our_h2 - h2) / np.linalg.norm(h2))
        worst, worst_matrix = max(worst, rows), max(worst_matrix, matrix)
        dropped = int((~kept).sum())
        print(f"  {name}: {int(kept.sum())} kept ({dropped} dropped, {int(outliers.sum())} outliers made), "
              f"rows differ by up to {rows:.2e} px, matrices by {matrix:.1e} relative")
        if rows > ROW_AGREEMENT_PX:
            failures.append(f"{name}: rectified rows differ from OpenCV's by up to {rows:.3f} px "
                            f"(at most {ROW_AGREEMENT_PX} px)")
    print(f"  worst row difference {worst:.2e} px (limit {ROW_AGREEMENT_PX} px); "
          f"matrices agree to {worst_matrix:.1e} relative")


def read_camera(path):
    data = yaml.safe_load(Path(path).read_text())
    k = np.array(data["camera_matrix"]["data"], dtype=np.float64).reshape(3, 3)
    d = np.array(data["distortion_coefficients"]["data"], dtype=np.float64)
    return k, d


def header(stamp, frame_id):
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=stamp[0], nanosec=stamp[1]), frame_id=frame_id)


def read_images(bag, topics):
    """{topic: {(sec, nanosec): grey image}} of the mono8 images on `topics`."""
    out = {t: {} for t in topics}
    with Reader(bag) as reader:
        connections = [c for c in reader.connections if c.topic in topics]
        for connection, _, raw in reader.messages(connections=connections):
            msg = ts.deserialize_cdr(raw, connection.msgtype)
            img = np.frombuffer(msg.data, dtype=np.uint8).reshape(msg.height, msg.step)[:, :msg.width]
            out[connection.topic][(msg.header.stamp.sec, msg.header.stamp.nanosec)] = np.ascontiguousarray(img)
    return out


def verged_pair(scene, out_bag):
    """Writes the scene's images as a distortion-free verged pair; returns them by stamp."""
    cameras = {"left": read_camera(scene / "left.yaml"), "right": read_camera(scene / "right.yaml")}
    turns = {"left": rotation(0.0, np.radians(3.0), 0.0),
             "right": rotation(0.0, np.radians(-3.0), np.radians(1.5))}
    maps = {}
    for side, (k, d) in cameras.items():
        maps[side] = cv2.initUndistortRectifyMap(k, d, turns[side], k, (WIDTH, HEIGHT), cv2.CV_32FC1)
    raw = read_images(scene / "bag", ["/stereo/left/image_raw", "/stereo/right/image_raw"])
    pair = {}
    with Writer(out_bag, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {side: writer.add_connection(f"/cam/{side}/image_raw", "sensor_msgs/msg/Image", typestore=ts)
                 for side in cameras}
        for stamp in sorted(raw["/stereo/left/image_raw"]):
            for side in cameras:
                img = cv2.remap(raw[f"/stereo/{side}/image_raw"][stamp], *maps[side], cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_CONSTANT, borderValue=0)
                pair.setdefault(stamp, {})[side] = img
                msg = T["sensor_msgs/msg/Image"](header=header(stamp, f"cam_{side}"), height=HEIGHT, width=WIDTH,
                                                 encoding="mono8", is_bigendian=0, step=WIDTH, data=img.reshape(-1))
                t = stamp[0] * 1_000_000_000 + stamp[1] + (0 if side == "left" else 1000)
                writer.write(conns[side], t, ts.serialize_cdr(msg, "sensor_msgs/msg/Image"))
    return pair


def corners(img):
    """OpenCV's chessboard corners: findChessboardCorners + cornerSubPix, or
    findChessboardCornersSB where the first finds no board (a board stretched by the warp)."""
    found, c = cv2.findChessboardCorners(img, BOARD, flags=cv2.CALIB_CB_ADAPTIVE_THRESH)
    if found:
        return cv2.cornerSubPix(img, c, (5, 5), (-1, -1),
                                (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-4)).reshape(-1, 2)
    found, c = cv2.findChessboardCornersSB(img, BOARD)
    return c.reshape(-1, 2) if found else None


def row_offsets(pairs, may_be_turned=True):
    """|row difference| of every chessboard corner found in both images of each pair."""
    offsets, frames = [], 0
    for left, right in pairs:
        a, b = corners(left), corners(right)
        if a is None or b is None:
            continue
        # Rectification may turn both images by 180 degrees, and a detector then label
        # the board from its other end in one of them.
        if may_be_turned and np.linalg.norm(a[0] - b[0]) > np.linalg.norm(a[0] - b[-1]):
            b = b[::-1]
        offsets.extend(np.abs(a[:, 1] - b[:, 1]))
        frames += 1
    return np.array(offsets), frames


def opencv_pipeline(pair):
    """OpenCV's own uncalibrated rectification of the pair, warped by warpPerspective."""
    left, right = [], []
    for images in pair.values():
        a, b = corners(images["left"]), corners(images["right"])
        if a is not None and b is not None:
            left.append(a)
            right.append(b)
    left, right = np.concatenate(left), np.concatenate(right)
    f, _ = cv2.findFundamentalMat(left, right, cv2.FM_RANSAC, 1.0, 0.999)
    _, h1, h2 = cv2.stereoRectifyUncalibrated(left, right, f, (WIDTH, HEIGHT), threshold=5.0)
    return [(cv2.warpPerspective(i["left"], h1, (WIDTH, HEIGHT)),
             cv2.warpPerspective(i["right"], h2, (WIDTH, HEIGHT))) for i in pair.values()]


def check_rendered(args, failures):
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        run = lambda *a: subprocess.run([str(args.bin), *map(str, a)], check=True, capture_output=True, text=True)
        run("synth", "--scene", "stereo", "--out", tmp / "scene", "--frames", args.frames, "--seed", args.seed)
        truth = json.loads((tmp / "scene" / "ground_truth.json").read_text())
        clean = {(f["stamp"]["sec"], f["stamp"]["nanosec"]) for f in truth["frames"] if f["kind"] == "clean"}
        pair = verged_pair(tmp / "scene", tmp / "verged")
        done = run("rectify", "--bag", tmp / "verged", "--out", tmp / "rectified", "--uncalibrated",
                   "--pattern", "chessboard", "--size", f"{BOARD[0]}x{BOARD[1]}", "--square", "0.04")
        rect = read_images(tmp / "rectified", ["/cam/left/image_rect", "/cam/right/image_rect"])
        ours = [(rect["/cam/left/image_rect"][s], rect["/cam/right/image_rect"][s])
                for s in sorted(clean) if s in rect["/cam/left/image_rect"]]
        theirs = opencv_pipeline({s: pair[s] for s in sorted(clean) if s in pair})
    before, before_frames = row_offsets([(i["left"], i["right"]) for s, i in sorted(pair.items()) if s in clean],
                                        may_be_turned=False)
    offsets, frames = row_offsets(ours)
    cv_offsets, cv_frames = row_offsets(theirs)
    print(f"\nrendered verged pair ({len(clean)} clean frames, corners found by OpenCV in the rectified images):")
    print(f"  {done.stderr.strip().splitlines()[0]}")
    print(f"  before rectification             mean |dy| {before.mean():.3f} px, max {before.max():.3f} px "
          f"over {len(before)} corners in {before_frames} frames")
    if frames == 0:
        failures.append("no chessboard found in our rectified pair")
        return
    print(f"  stereocal rectify --uncalibrated mean |dy| {offsets.mean():.4f} px, max {offsets.max():.4f} px "
          f"over {len(offsets)} corners in {frames} frames")
    if cv_frames:
        print(f"  OpenCV stereoRectifyUncalibrated mean |dy| {cv_offsets.mean():.4f} px, "
              f"max {cv_offsets.max():.4f} px over {len(cv_offsets)} corners in {cv_frames} frames")
    if frames < before_frames:
        failures.append(f"the chessboard was found in {frames} rectified pairs, in {before_frames} before")
    if offsets.max() > ROW_ALIGNMENT_PX:
        failures.append(f"rectified rows differ by up to {offsets.max():.3f} px (at most {ROW_ALIGNMENT_PX} px)")


def default_binary(*parts):
    release = REPO / "target" / "release" / Path(*parts)
    return release if release.exists() else REPO / "target" / "debug" / Path(*parts)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--example", type=Path, default=default_binary("examples", "rectify_uncalibrated"))
    parser.add_argument("--bin", type=Path, default=default_binary("stereocal"))
    parser.add_argument("--problems", type=int, default=8)
    parser.add_argument("--points", type=int, default=300)
    parser.add_argument("--thresholds", type=float, nargs="+", default=[2.0, 5.0])
    parser.add_argument("--frames", type=int, default=6)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    cv2.setNumThreads(1)
    failures = []
    check_homographies(args, failures)
    check_rendered(args, failures)
    if failures:
        print("\nFAILED:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print("\nuncalibrated rectification: all checks passed")


if __name__ == "__main__":
    main()
