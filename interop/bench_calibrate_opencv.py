#!/usr/bin/env python3
"""Calibration speed, stereocal against OpenCV, side by side in one run.

`stereocal synth --scene calibration` renders a stereo calibration session (20 pairs of
1280x720 by default, about one frame in ten blurred, moving or partly out of view).
Its images are written as PNG, then timed, median over --repeats runs of each:

(a) detection per image: stereocal (the `calib_timing` example) against
    cv2.findChessboardCorners (default flags) + cv2.cornerSubPix (11x11 window, 30
    iterations / 0.001, as OpenCV's calibration tutorial) on the same decoded images
    (decoding is not timed), in rounds of one pass of each. One thread: one image after the other with one thread
    each (cv2.setNumThreads(1), a one-thread rayon pool). All threads: the images
    spread over one worker per core (a thread pool calling OpenCV, which releases the
    GIL; a rayon pool for stereocal). Reported: the mean per image over all images
    (frames without a whole board included: OpenCV spends much longer on them), and
    the median of each image's time over the images both found the board in. Also on
    the real 640x480 pairs of ../shared/data/opencv-stereo when that folder is there.
(b) the mono solve on the same corners (stereocal's, from (a)): calibrate_mono
    against cv2.calibrateCamera, plumb_bob with every view kept, per camera; and the
    stereo solve with the intrinsics held against cv2.stereoCalibrate
    (CALIB_FIX_INTRINSIC).
(c) the whole command: `stereocal calibrate --bag ...` against this script's OpenCV
    pipeline run as its own process (`--opencv-pipeline`): read the bag with rosbags,
    findChessboardCorners + cornerSubPix on every image, calibrateCamera per camera,
    stereoCalibrate, stereoRectify, camera_info YAML files written. stereocal with
    its default threads (all cores) and with RAYON_NUM_THREADS=1; OpenCV with its
    default threads, one image after the other as the tutorials do.

Ratios are OpenCV time / stereocal time: above 1, stereocal is faster. Absolute times
depend on the machine and its load; the ratios are what to compare.

Usage: .venv/bin/python interop/bench_calibrate_opencv.py
       [--bin target/release/stereocal] [--example target/release/examples/calib_timing]
       [--frames 20] [--width 1280 --height 720] [--repeats 5] [--real DIR]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from check_calibrate_opencv import TOPICS, read_images  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
CORES = os.cpu_count() or 1


def opencv_detect(gray, size):
    found, corners = cv2.findChessboardCorners(gray, size)
    if found:
        corners = cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1), CRITERIA)
    return corners if found else None


def median_time(run, repeats):
    """Median seconds of `repeats` calls of run() after one warm-up call."""
    run()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def opencv_detection_round(images, size, pool):
    """One round: each image's seconds with one thread, and the mean seconds per image
    with one worker per core."""
    cv2.setNumThreads(1)
    each = []
    for gray in images:
        start = time.perf_counter()
        opencv_detect(gray, size)
        each.append(time.perf_counter() - start)
    cv2.setNumThreads(0)
    start = time.perf_counter()
    list(pool.map(lambda g: opencv_detect(g, size), images))
    return each, (time.perf_counter() - start) / len(images)


def ours(example, command, args):
    out = subprocess.run([str(example), command, *map(str, args)], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out)


def detection_rows(label, example, paths, size, repeats, corners=None):
    """Rounds of OpenCV then stereocal, so that a change of the machine's load between
    them weighs on both; medians over the rounds."""
    images = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in paths]
    cv_found = [opencv_detect(g, size) is not None for g in images]
    extra = ["--corners", corners] if corners else []
    common = ["--size", f"{size[0]}x{size[1]}", "--repeats", 1, *extra, *paths]
    rounds = {"cv_each": [], "cv_all": [], "our_each": [], "our_all": []}
    with ThreadPoolExecutor(CORES) as pool:
        for _ in range(repeats):
            each, every = opencv_detection_round(images, size, pool)
            rounds["cv_each"].append(each)
            rounds["cv_all"].append(every)
            one = ours(example, "detect", ["--threads", 1, *common])
            rounds["our_each"].append(one["seconds_each"])
            rounds["our_all"].append(ours(example, "detect", ["--threads", 0, *common])["seconds_per_image"])
    our_found = one["detected"]

    def per_image(key):
        return [statistics.median(r[i] for r in rounds[key]) for i in range(len(images))]

    cv_each, our_each = per_image("cv_each"), per_image("our_each")
    both = [i for i, (a, b) in enumerate(zip(cv_found, our_found)) if a and b]
    h, w = images[0].shape
    print(f"\n(a) detection per image, {label}: {len(images)} images of {w}x{h}, "
          f"found by stereocal {sum(our_found)}, by OpenCV {sum(cv_found)}; ms")
    rows = (
        ("mean, 1 thread", statistics.fmean(cv_each), statistics.fmean(our_each)),
        (f"mean, {CORES} threads", statistics.median(rounds["cv_all"]),
         statistics.median(rounds["our_all"])),
        (f"median over the {len(both)} found by both, 1 thread",
         statistics.median(cv_each[i] for i in both), statistics.median(our_each[i] for i in both)),
    )
    for name, cv_s, our_s in rows:
        print(f"    {name:42} OpenCV {cv_s * 1e3:7.2f}   stereocal {our_s * 1e3:7.2f}   "
              f"ratio {cv_s / our_s:5.2f}x")


def solve_rows(example, corners_path, repeats):
    corners = json.loads(Path(corners_path).read_text())
    size = tuple(corners["image_size"])
    obj = np.array(corners["object_points"], dtype=np.float32)
    views = {"left": {}, "right": {}}
    for name, found in corners["images"].items():
        camera, frame = name.rsplit("_", 1)
        if found is not None:
            views[camera][frame] = np.array(found, dtype=np.float32).reshape(-1, 1, 2)
    print(f"\n(b) solves on stereocal's corners ({len(views['left'])} left, "
          f"{len(views['right'])} right views), ms")
    ratios = {}
    for threads in (1, 0):
        cv2.setNumThreads(threads)
        label = "1 thread" if threads == 1 else f"{CORES} threads"
        mine = ours(example, "mono", ["--corners", corners_path, "--repeats", repeats,
                                      "--threads", threads])
        intrinsics = {}
        for camera in ("left", "right"):
            pts = list(views[camera].values())
            cv_s = median_time(lambda: cv2.calibrateCamera([obj] * len(pts), pts, size, None, None),
                               repeats)
            _, k, d, _, _ = cv2.calibrateCamera([obj] * len(pts), pts, size, None, None)
            intrinsics[camera] = (k, d)
            our_s = mine[camera]["seconds"]
            ratios[f"mono {camera}, {label}"] = cv_s / our_s
            print(f"    mono {camera:5} {label:10} OpenCV {cv_s * 1e3:8.2f}   "
                  f"stereocal {our_s * 1e3:8.2f}   ratio {cv_s / our_s:5.2f}x")
        common = sorted(set(views["left"]) & set(views["right"]))
        left = [views["left"][f] for f in common]
        right = [views["right"][f] for f in common]
        (k1, d1), (k2, d2) = intrinsics["left"], intrinsics["right"]
        cv_s = median_time(lambda: cv2.stereoCalibrate(
            [obj] * len(common), left, right, k1, d1, k2, d2, size,
            flags=cv2.CALIB_FIX_INTRINSIC), repeats)
        our_s = ours(example, "stereo", ["--corners", corners_path, "--repeats", repeats,
                                         "--threads", threads])["seconds"]
        ratios[f"stereo, {label}"] = cv_s / our_s
        print(f"    stereo     {label:10} OpenCV {cv_s * 1e3:8.2f}   "
              f"stereocal {our_s * 1e3:8.2f}   ratio {cv_s / our_s:5.2f}x  ({len(common)} pairs)")
    cv2.setNumThreads(0)
    return ratios


def camera_yaml(path, name, size, k, d, r, p):
    def matrix(rows, cols, m):
        data = ", ".join(f"{v:.12g}" for v in np.asarray(m, dtype=float).ravel())
        return f"  rows: {rows}\n  cols: {cols}\n  data: [{data}]\n"
    text = (f"image_width: {size[0]}\nimage_height: {size[1]}\ncamera_name: {name}\n"
            f"camera_matrix:\n{matrix(3, 3, k)}distortion_model: plumb_bob\n"
            f"distortion_coefficients:\n{matrix(1, 5, d)}"
            f"rectification_matrix:\n{matrix(3, 3, r)}projection_matrix:\n{matrix(3, 4, p)}")
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(path)


def opencv_pipeline(bag, out, cols, rows, square):
    """What `stereocal calibrate` does, the way OpenCV's tutorials do it."""
    images = read_images(bag)
    objp = np.zeros((cols * rows, 3), np.float32)
    objp[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square
    corners, size = {}, None
    for topic in TOPICS:
        corners[topic] = {}
        for stamp, img in images[topic].items():
            size = (img.shape[1], img.shape[0])
            found = opencv_detect(img, (cols, rows))
            if found is not None:
                corners[topic][stamp] = found
    cameras = []
    for topic in TOPICS:
        views = list(corners[topic].values())
        _, k, d, _, _ = cv2.calibrateCamera([objp] * len(views), views, size, None, None)
        cameras.append((k, d))
    common = sorted(set(corners[TOPICS[0]]) & set(corners[TOPICS[1]]))
    (k1, d1), (k2, d2) = cameras
    _, k1, d1, k2, d2, r, t, _, _ = cv2.stereoCalibrate(
        [objp] * len(common), [corners[TOPICS[0]][s] for s in common],
        [corners[TOPICS[1]][s] for s in common], k1, d1, k2, d2, size,
        flags=cv2.CALIB_FIX_INTRINSIC)
    r1, r2, p1, p2, _, _, _ = cv2.stereoRectify(k1, d1, k2, d2, size, r, t)
    out.mkdir(parents=True, exist_ok=True)
    camera_yaml(out / "left.yaml", "left", size, k1, d1, r1, p1)
    camera_yaml(out / "right.yaml", "right", size, k2, d2, r2, p2)


def whole_rows(args, bag, out, cols, rows, square, repeats):
    ours_cmd = [str(args.bin), "calibrate", "--bag", str(bag), "--out", str(out / "ours"),
                "--size", f"{cols}x{rows}", "--square", str(square)]
    cv_cmd = [sys.executable, __file__, "--opencv-pipeline", str(bag), str(out / "opencv"),
              "--size", f"{cols}x{rows}", "--square", str(square)]

    one_thread = dict(os.environ, RAYON_NUM_THREADS="1")
    runs = {"ours_all": (ours_cmd, None), "ours_one": (ours_cmd, one_thread), "opencv": (cv_cmd, None)}
    times = {name: [] for name in runs}
    # A first round untimed (file cache), then rounds of each, medians over the rounds.
    for round_ in range(repeats + 1):
        for name, (cmd, env) in runs.items():
            start = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True, env=env)
            if round_:
                times[name].append(time.perf_counter() - start)
    ours_all, ours_one, opencv = (statistics.median(times[n]) for n in ("ours_all", "ours_one", "opencv"))
    start = time.perf_counter()
    opencv_pipeline(bag, out / "opencv_in_process", cols, rows, square)
    in_process = time.perf_counter() - start
    print("\n(c) the whole calibration of the bag (process wall time, s)")
    print(f"    OpenCV script {opencv:6.3f} (of which {in_process:6.3f} after the interpreter "
          f"started and imported cv2)")
    print(f"    stereocal calibrate, {CORES} threads {ours_all:6.3f}   ratio {opencv / ours_all:5.2f}x "
          f"({in_process / ours_all:5.2f}x against the script's pipeline alone)")
    print(f"    stereocal calibrate, 1 thread  {ours_one:6.3f}   ratio {opencv / ours_one:5.2f}x "
          f"({in_process / ours_one:5.2f}x against the script's pipeline alone)")


def default_path(*parts):
    return REPO.joinpath("target", "release", *parts)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bin", type=Path, default=default_path("stereocal"))
    parser.add_argument("--example", type=Path, default=default_path("examples", "calib_timing"))
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=720)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--real", type=Path, default=REPO.parent / "shared/data/opencv-stereo")
    parser.add_argument("--opencv-pipeline", nargs=2, type=Path, metavar=("BAG", "OUT"))
    parser.add_argument("--size", default="9x6")
    parser.add_argument("--square", type=float, default=0.04)
    args = parser.parse_args()
    if args.opencv_pipeline:
        cols, rows = map(int, args.size.split("x"))
        opencv_pipeline(*args.opencv_pipeline, cols, rows, args.square)
        return
    for tool, build in ((args.bin, "cargo build --release --bin stereocal"),
                        (args.example, "cargo build --release -p stereocal-vision --example calib_timing")):
        if not tool.exists():
            sys.exit(f"{tool} is missing: {build}")

    print(f"OpenCV {cv2.__version__}, {CORES} cores; medians of {args.repeats} runs")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        session = tmp / "session"
        subprocess.run([str(args.bin), "synth", "--scene", "calibration", "--out", str(session),
                        "--frames", str(args.frames), "--seed", str(args.seed),
                        "--width", str(args.width), "--height", str(args.height)],
                       check=True, capture_output=True)
        board = json.loads((session / "ground_truth.json").read_text())["board"]
        cols, rows = board["inner_corners_cols"], board["inner_corners_rows"]
        square = board["square_size_m"]
        frames = tmp / "frames"
        frames.mkdir()
        paths = []
        images = read_images(session / "bag")
        for topic, camera in zip(TOPICS, ("left", "right")):
            for index, (_, img) in enumerate(sorted(images[topic].items())):
                path = frames / f"{camera}_{index:03}.png"
                cv2.imwrite(str(path), img)
                paths.append(path)
        corners = tmp / "corners.json"
        detection_rows(f"synthetic session (seed {args.seed})", args.example, paths,
                       (cols, rows), args.repeats, corners)
        if args.real.is_dir():
            # Decoded once by OpenCV so that both read the same pixels.
            real = []
            for jpeg in sorted(args.real.glob("left*.jpg")) + sorted(args.real.glob("right*.jpg")):
                real.append(frames / f"real_{jpeg.stem}.png")
                cv2.imwrite(str(real[-1]), cv2.imread(str(jpeg), cv2.IMREAD_GRAYSCALE))
            detection_rows(f"real pairs in {args.real}", args.example, real, (9, 6), args.repeats)
        else:
            print(f"\n{args.real} is absent: no detection timing on real images")
        solve_rows(args.example, corners, max(args.repeats, 10))
        whole_rows(args, session / "bag", tmp / "out", cols, rows, square, args.repeats)


if __name__ == "__main__":
    main()
