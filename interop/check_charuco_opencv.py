"""stereocal's ChArUco detector against OpenCV's `cv2.aruco.CharucoDetector` and the truth.

`stereocal synth --scene calibration --board config/boards/charuco_10x7_40mm.yaml`
renders a stereo session of a ChArUco board (a quarter of the frames bad: blurred,
moving, partly out of view) with its ground truth. Every image is searched by
stereocal (the `detect_target` example) and by OpenCV 4.x's CharucoDetector (default
parameters, the same board). Printed: images detected by each, corner ids found,
corner errors against the truth (mean / median / max on clean frames), and the
distance between the two detectors' corners of the same id.

Exits non-zero on a mismatch: a stereocal corner farther than 0.5 px from the truth
of its id (a wrong id), an id stereocal reports that the camera does not see, a clean
frame where OpenCV finds the board (6 or more corners) and stereocal does not, fewer
corners than 95 % of OpenCV's on the clean frames, or a median error on clean frames
above 0.03 px.

Usage: .venv/bin/python interop/check_charuco_opencv.py [--frames N] [--seed S]
       [--board config/boards/X.yaml] [--bin path/to/stereocal]
       [--detect path/to/detect_target]
"""

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np
from bag_images import grey_images

REPO = Path(__file__).resolve().parent.parent
TOPICS = {"/stereo/left/image_raw": "left", "/stereo/right/image_raw": "right"}


def built(path):
    release = REPO / "target" / "release" / path
    return release if release.exists() else REPO / "target" / "debug" / path


def read_board(path):
    """The `key: value` lines of a board file (`config/boards/*.yaml`), numbers parsed."""
    board = {}
    for line in path.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if ":" not in line:
            continue
        key, value = (part.strip() for part in line.split(":", 1))
        try:
            board[key] = int(value)
        except ValueError:
            try:
                board[key] = float(value)
            except ValueError:
                board[key] = value
    return board


def opencv_detector(board):
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, board["dictionary"]))
    charuco = cv2.aruco.CharucoBoard(
        (board["squares_x"], board["squares_y"]),
        board["square_size"],
        board["marker_size"],
        dictionary,
    )
    return cv2.aruco.CharucoDetector(charuco)


def opencv_detect(detector, img):
    """{id: (x, y)} of OpenCV's ChArUco corners."""
    corners, ids, _, _ = detector.detectBoard(img)
    if ids is None:
        return {}
    return {int(i): tuple(map(float, c)) for i, c in zip(ids.ravel(), corners.reshape(-1, 2))}


def stereocal_detect(binary, board_file, paths):
    """{path: {id: (x, y)}} of stereocal's corners."""
    out = subprocess.run(
        [str(binary), str(board_file), *map(str, paths)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    found = {}
    for line in out.splitlines():
        record = json.loads(line)
        ids = record["ids"] or []
        corners = record["corners"] or []
        found[record["image"]] = {int(i): tuple(c) for i, c in zip(ids, corners)}
    return found


def stats(values):
    if not values:
        return "none"
    v = np.asarray(values)
    return f"mean {v.mean():.4f} px, median {np.median(v):.4f} px, max {v.max():.4f} px ({len(v)} corners)"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--board", type=Path, default=REPO / "config/boards/charuco_10x7_40mm.yaml")
    parser.add_argument("--bin", type=Path, default=built("stereocal"))
    parser.add_argument("--detect", type=Path, default=built("examples/detect_target"))
    args = parser.parse_args()
    board = read_board(args.board)
    if board.get("pattern") != "charuco":
        sys.exit(f"{args.board} is not a ChArUco board")

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        subprocess.run(
            [str(args.bin), "synth", "--scene", "calibration", "--board", str(args.board),
             "--frames", str(args.frames), "--seed", str(args.seed), "--bad-frames", "0.25",
             "--out", str(tmp / "scene")],
            check=True,
        )
        truth = json.loads((tmp / "scene" / "ground_truth.json").read_text())
        images = {
            (TOPICS[topic], stamp): img
            for topic, stamp, img in grey_images(tmp / "scene" / "bag", TOPICS)
        }
        paths = {}
        for (camera, stamp), img in images.items():
            path = tmp / f"{camera}_{stamp[0]}_{stamp[1]:09d}.png"
            cv2.imwrite(str(path), img)
            paths[(camera, stamp)] = path
        ours = stereocal_detect(args.detect, args.board, list(paths.values()))
        detector = opencv_detector(board)

        failures = []
        errors = {"stereocal": [], "opencv": []}
        between = []
        counts = {"stereocal": 0, "opencv": 0, "images": 0}
        ids_found = {"stereocal": 0, "opencv": 0}
        clean_found = {"stereocal": 0, "opencv": 0}
        for frame in truth["frames"]:
            stamp = (frame["stamp"]["sec"], frame["stamp"]["nanosec"])
            for view in frame["views"]:
                key = (view["camera"], stamp)
                where = f"frame {frame['index']} ({frame['kind']}) {view['camera']}"
                truth_px = {c["id"]: c["pixel"] for c in view["corners"] if c["visible"]}
                mine = ours.get(str(paths[key]), {})
                theirs = opencv_detect(detector, images[key])
                counts["images"] += 1
                for name, found in (("stereocal", mine), ("opencv", theirs)):
                    counts[name] += bool(found)
                    ids_found[name] += len(found)
                    if frame["kind"] == "clean":
                        clean_found[name] += len(found)
                for i, (x, y) in mine.items():
                    if i not in truth_px:
                        failures.append(f"{where}: stereocal reports corner {i}, not in view")
                        continue
                    err = float(np.hypot(x - truth_px[i][0], y - truth_px[i][1]))
                    if err > 0.5:
                        failures.append(f"{where}: stereocal corner {i} is {err:.2f} px from the truth")
                    if frame["kind"] == "clean":
                        errors["stereocal"].append(err)
                for i, (x, y) in theirs.items():
                    if frame["kind"] == "clean" and i in truth_px:
                        errors["opencv"].append(float(np.hypot(x - truth_px[i][0], y - truth_px[i][1])))
                    if i in mine:
                        between.append(float(np.hypot(x - mine[i][0], y - mine[i][1])))
                if frame["kind"] == "clean" and len(theirs) >= 6 and not mine:
                    failures.append(f"{where}: OpenCV finds {len(theirs)} corners, stereocal none")
                only_cv = sorted(set(theirs) - set(mine))
                only_us = sorted(set(mine) - set(theirs))
                if only_cv or only_us:
                    print(f"{where}: ids only OpenCV found {only_cv}, only stereocal found {only_us}")

    print(f"images with the board found: stereocal {counts['stereocal']}, OpenCV {counts['opencv']} of {counts['images']}")
    print(f"corners found: stereocal {ids_found['stereocal']}, OpenCV {ids_found['opencv']}")
    print(f"clean frames, stereocal against truth: {stats(errors['stereocal'])}")
    print(f"clean frames, OpenCV against truth:    {stats(errors['opencv'])}")
    print(f"stereocal against OpenCV, same ids:    {stats(between)}")
    if errors["stereocal"] and float(np.median(errors["stereocal"])) > 0.03:
        failures.append(f"median corner error on clean frames {np.median(errors['stereocal']):.4f} px > 0.03 px")
    if clean_found["stereocal"] < 0.95 * clean_found["opencv"]:
        failures.append(
            f"on clean frames stereocal finds {clean_found['stereocal']} corners, OpenCV {clean_found['opencv']}"
        )
    if not errors["stereocal"]:
        failures.append("stereocal found no corner on a clean frame")
    for failure in failures:
        print("MISMATCH:", failure)
    if failures:
        sys.exit(1)
    print("ChArUco detection agrees with OpenCV and the truth")


if __name__ == "__main__":
    main()
