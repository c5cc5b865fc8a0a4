#!/usr/bin/env python3
"""ChArUco detection speed, stereocal against OpenCV's CharucoDetector, side by side in one run.

`stereocal synth --scene calibration --board config/boards/charuco_10x7_40mm.yaml`
renders a stereo session of a ChArUco board (1024x768; a quarter of the frames bad:
blurred, moving or partly out of view), and its images are written as PNG, as in
interop/check_charuco_opencv.py. Each image is then timed on one thread:

- OpenCV: `cv2.aruco.CharucoDetector(board).detectBoard` (default parameters) with
  `cv2.setNumThreads(1)`, median of --repeats calls on the decoded image after one
  warm-up call;
- stereocal: the `detect_target` example with `--repeats` (the median of as many
  detections of the decoded image, PNG decoding not timed), with RAYON_NUM_THREADS=1;
- optionally a second stereocal build (`--baseline path/to/detect_target`), to compare
  two builds against the same OpenCV in the same run.

The sides take turns in --rounds rounds, in a different order each round, so that a
change of the machine's load weighs on all of them alike. Per image, the fastest and
the median of its round times are kept; reported are, per side, the median over the
images of each, the mean per image (round medians), and the ratios OpenCV time /
stereocal time (above 1, stereocal is faster) of the minima and of the medians, over
all images and over the clean and the bad frames apart. Absolute times depend on the
machine and its load; compare the ratios.

Usage: .venv/bin/python interop/bench_charuco_opencv.py [--rounds 5] [--repeats 5]
       [--frames 12] [--seed 5] [--board config/boards/charuco_10x7_40mm.yaml]
       [--bin target/release/stereocal] [--detect target/release/examples/detect_target]
       [--baseline OTHER/detect_target]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bag_images import grey_images  # noqa: E402
from check_charuco_opencv import TOPICS, opencv_detector, read_board  # noqa: E402

REPO = Path(__file__).resolve().parent.parent


def opencv_round(detector, images, repeats):
    """Each image's median seconds over `repeats` detectBoard calls, and whether it found
    a board (6 or more corners)."""
    cv2.setNumThreads(1)
    seconds, found = [], []
    for img in images:
        corners, ids, _, _ = detector.detectBoard(img)
        found.append(ids is not None and len(ids) >= 6)
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            detector.detectBoard(img)
            times.append(time.perf_counter() - start)
        seconds.append(statistics.median(times))
    return seconds, found


def stereocal_round(binary, board, paths, repeats):
    """Each image's median seconds over `repeats` detections by `detect_target`, and
    whether it found the board."""
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    out = subprocess.run(
        [str(binary), "--repeats", str(repeats), str(board), *map(str, paths)],
        check=True, capture_output=True, text=True, env=env,
    ).stdout
    records = {r["image"]: r for r in map(json.loads, out.splitlines())}
    records = [records[str(p)] for p in paths]
    return [r["seconds"] for r in records], [r["ids"] is not None for r in records]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--board", type=Path, default=REPO / "config/boards/charuco_10x7_40mm.yaml")
    parser.add_argument("--bin", type=Path, default=REPO / "target/release/stereocal")
    parser.add_argument("--detect", type=Path, default=REPO / "target/release/examples/detect_target")
    parser.add_argument("--baseline", type=Path, help="another build's detect_target, timed alike")
    args = parser.parse_args()
    for tool, build in ((args.bin, "cargo build --release --bin stereocal"),
                        (args.detect, "cargo build --release -p stereocal-vision --example detect_target"),
                        (args.baseline, "")):
        if tool is not None and not tool.exists():
            sys.exit(f"{tool} is missing {build}".rstrip())
    board = read_board(args.board)
    if board.get("pattern") != "charuco":
        sys.exit(f"{args.board} is not a ChArUco board")

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        subprocess.run(
            [str(args.bin), "synth", "--scene", "calibration", "--board", str(args.board),
             "--frames", str(args.frames), "--seed", str(args.seed), "--bad-frames", "0.25",
             "--out", str(tmp / "scene")],
            check=True, capture_output=True,
        )
        truth = json.loads((tmp / "scene" / "ground_truth.json").read_text())
        kinds = {(f["stamp"]["sec"], f["stamp"]["nanosec"]): f["kind"] for f in truth["frames"]}
        images, paths, clean = [], [], []
        for topic, stamp, img in grey_images(tmp / "scene" / "bag", TOPICS):
            path = tmp / f"{TOPICS[topic]}_{stamp[0]}_{stamp[1]:09d}.png"
            cv2.imwrite(str(path), img)
            images.append(img)
            paths.append(path)
            clean.append(kinds[stamp] == "clean")

        detector = opencv_detector(board)
        sides = {"OpenCV": lambda: opencv_round(detector, images, args.repeats),
                 "stereocal": lambda: stereocal_round(args.detect, args.board, paths, args.repeats)}
        if args.baseline:
            sides["baseline"] = lambda: stereocal_round(args.baseline, args.board, paths, args.repeats)
        names = list(sides)
        rounds = {name: [] for name in names}
        found = {}
        for r in range(args.rounds):
            for name in names[r % len(names):] + names[: r % len(names)]:
                seconds, found[name] = sides[name]()
                rounds[name].append(seconds)

    h, w = images[0].shape
    print(f"OpenCV {cv2.__version__}; {len(images)} images of {w}x{h} "
          f"({sum(clean)} of clean frames), {args.rounds} rounds of {args.repeats} repeats, "
          f"one thread each")
    print("found the board: " + ", ".join(f"{n} {sum(found[n])}" for n in names))
    fastest = {n: [min(r[i] for r in rounds[n]) for i in range(len(images))] for n in names}
    median = {n: [statistics.median(r[i] for r in rounds[n]) for i in range(len(images))]
              for n in names}
    groups = (("all images", range(len(images))),
              ("clean frames", [i for i in range(len(images)) if clean[i]]),
              ("bad frames", [i for i in range(len(images)) if not clean[i]]))
    for label, which in groups:
        if not which:
            continue
        print(f"\n{label} ({len(which)}), ms per image: median of the fastest / median of the "
              f"medians / mean of the medians")
        stat = {n: (statistics.median(fastest[n][i] for i in which),
                    statistics.median(median[n][i] for i in which),
                    statistics.fmean(median[n][i] for i in which)) for n in names}
        for n in names:
            a, b, c = stat[n]
            line = f"    {n:10} {a * 1e3:8.2f} {b * 1e3:8.2f} {c * 1e3:8.2f}"
            if n != "OpenCV":
                cv = stat["OpenCV"]
                line += (f"   OpenCV / {n}: minima {cv[0] / a:5.2f}x, medians {cv[1] / b:5.2f}x, "
                         f"means {cv[2] / c:5.2f}x")
            print(line)


if __name__ == "__main__":
    main()
