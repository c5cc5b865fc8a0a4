"""Checks camera_node's YUYV conversion against OpenCV, bit for bit.

Random YUYV buffers (several sizes, and one holding every extreme of Y, U and V) are
converted by stereocal's `yuyv_convert` example (the functions camera_node publishes
`image_raw` with) and by OpenCV's `cvtColor` with `COLOR_YUV2RGB_YUYV` and
`COLOR_YUV2GRAY_YUYV`. Exits non-zero unless every pixel is identical.

    .venv/bin/python interop/check_yuyv_opencv.py [--example target/debug/examples/yuyv_convert]
"""

import argparse
import os
import subprocess
import sys
import tempfile

import cv2
import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def extremes():
    """A 2-row YUYV image whose pixel pairs take every combination of extreme values."""
    values = [0, 1, 15, 16, 17, 127, 128, 129, 235, 240, 254, 255]
    quads = [[y0, u, y1, v] for y0 in values for u in values for y1 in values[::3] for v in values]
    # An even number of quads, split over two rows.
    return np.array(quads, dtype=np.uint8).reshape(2, -1)


def cases(rng):
    sizes = [(640, 480), (2, 1), (1280, 720), (34, 17), (1920, 1080)]
    for width, height in sizes:
        yield f"random {width}x{height}", rng.integers(0, 256, (height, width * 2), dtype=np.uint8)
    grid = extremes()
    yield f"extremes {grid.shape[1] // 2}x{grid.shape[0]}", grid


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--example", default=os.path.join(REPO, "target/debug/examples/yuyv_convert"))
    args = parser.parse_args()
    rng = np.random.default_rng(13)
    failures = 0
    with tempfile.TemporaryDirectory() as tmp:
        for name, yuyv in cases(rng):
            height, width = yuyv.shape[0], yuyv.shape[1] // 2
            src = os.path.join(tmp, "in.yuyv")
            rgb_path, mono_path = os.path.join(tmp, "out.rgb"), os.path.join(tmp, "out.mono")
            np.ascontiguousarray(yuyv).tofile(src)
            subprocess.run([args.example, src, str(width), str(height), rgb_path, mono_path], check=True)
            ours_rgb = np.fromfile(rgb_path, dtype=np.uint8).reshape(height, width, 3)
            ours_mono = np.fromfile(mono_path, dtype=np.uint8).reshape(height, width)
            packed = yuyv.reshape(height, width, 2)
            cv_rgb = cv2.cvtColor(packed, cv2.COLOR_YUV2RGB_YUYV)
            cv_mono = cv2.cvtColor(packed, cv2.COLOR_YUV2GRAY_YUYV)
            rgb_diff = int(np.abs(ours_rgb.astype(int) - cv_rgb.astype(int)).max())
            mono_diff = int(np.abs(ours_mono.astype(int) - cv_mono.astype(int)).max())
            rgb_same = int((ours_rgb == cv_rgb).all(axis=2).sum())
            ok = rgb_diff == 0 and mono_diff == 0
            failures += 0 if ok else 1
            print(
                f"{'ok  ' if ok else 'FAIL'} {name}: rgb8 {rgb_same}/{width * height} pixels identical "
                f"(max difference {rgb_diff}), mono8 max difference {mono_diff}"
            )
    print(f"{6 - failures} passed, {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
