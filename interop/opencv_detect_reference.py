#!/usr/bin/env python3
"""OpenCV's corners on the real stereo sample pairs, as a fixture.

Runs findChessboardCorners (default flags) and cornerSubPix (winSize (5, 5), an
11x11-pixel window; criteria EPS|MAX_ITER 30/0.01) on the 26 images of
../shared/data/opencv-stereo and writes their corners, in OpenCV's order, to
vision/tests/fixtures/opencv_stereo_corners.json, which vision/tests/board_opencv_stereo.rs
compares our corners with and the calibration tests feed to our solver.

Usage: .venv/bin/python interop/opencv_detect_reference.py [DATA_DIR]
"""

import json
import re
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
PAIRS = [1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14]
PATTERN = (9, 6)
CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01)


def main() -> int:
    data = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT.parent / "shared/data/opencv-stereo"
    images = {}
    for side in ("left", "right"):
        for pair in PAIRS:
            name = f"{side}{pair:02d}.jpg"
            gray = cv2.imread(str(data / name), cv2.IMREAD_GRAYSCALE)
            if gray is None:
                print(f"cannot read {data / name}", file=sys.stderr)
                return 1
            found, corners = cv2.findChessboardCorners(gray, PATTERN)
            if not found:
                print(f"{name}: OpenCV found no board", file=sys.stderr)
                return 1
            corners = cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1), CRITERIA)
            images[name] = {
                "width": gray.shape[1],
                "height": gray.shape[0],
                "corners": np.asarray(corners, dtype=float).reshape(-1, 2).round(6).tolist(),
            }
    fixture = {
        "source": "../shared/data/opencv-stereo",
        "opencv_version": cv2.__version__,
        "pattern": {"cols": PATTERN[0], "rows": PATTERN[1]},
        "method": "findChessboardCorners (default flags) + cornerSubPix winSize (5, 5) "
        "zeroZone (-1, -1) criteria EPS|MAX_ITER 30/0.01",
        "images": images,
    }
    out = ROOT / "vision/tests/fixtures/opencv_stereo_corners.json"
    tmp = out.with_suffix(".json.tmp")
    text = json.dumps(fixture, indent=1)
    # One corner per line.
    text = re.sub(r"\[\s+(-?[0-9.e+-]+),\s+(-?[0-9.e+-]+)\s+\]", r"[\1, \2]", text)
    tmp.write_text(text + "\n")
    tmp.replace(out)
    print(f"wrote {len(images)} images to {out.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
