"""Checks stereocal's undistort/rectify maps and remap against OpenCV.

For plumb_bob, rational_polynomial and equidistant camera_info values (K, D, a small
rectification R and a new projection P), builds OpenCV's fixed-point maps
(initUndistortRectifyMap / fisheye.initUndistortRectifyMap, CV_16SC2) and remaps a
textured test image (mono8, rgb8, mono16) with nearest, bilinear and bicubic
interpolation and a constant border; runs stereocal's `remap_image` example on the same
input and compares. Prints the max/mean difference per model and image type and exits
non-zero when a map position differs by more than 1/32 pixel or a pixel by more than 1
grey level.

    .venv/bin/python interop/check_remap_opencv.py [--bin PATH] [--size 640x480]
    .venv/bin/python interop/check_remap_opencv.py --fixture vision/tests/fixtures/remap

`--fixture DIR` writes the small fixture that `vision/tests/remap_opencv_fixture.rs`
compares against: per model the camera parameters (160x120) and OpenCV's outputs.
Each case is a camera_info with a rectification R and a new projection P, as a stereo
rectification would give them, at a chosen image size.
"""

import argparse
import tempfile

import json
import os
import subprocess
import sys

import cv2
import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

INTERPOLATIONS = {
    "nearest": cv2.INTER_NEAREST,
    "bilinear": cv2.INTER_LINEAR,
    "bicubic": cv2.INTER_CUBIC,
}


def rotation(rx, ry, rz):
    r, _ = cv2.Rodrigues(np.array([rx, ry, rz], dtype=np.float64))
    return r


def cases(width, height):
    """camera_info-like dicts for plumb_bob, rational_polynomial and equidistant."""
    # Designed at 640x480; other sizes scale focal lengths with the width and the
    # principal point with each side.
    s, t = width / 640.0, height / 480.0
    k = [420.0 * s, 0.0, 322.5 * s, 0.0, 418.0 * s, 241.3 * t, 0.0, 0.0, 1.0]
    p = [400.0 * s, 0.0, 318.0 * s, -40.0 * s, 0.0, 400.0 * s, 244.0 * t, 0.0, 0.0, 0.0, 1.0, 0.0]
    r = rotation(0.012, -0.021, 0.004).flatten().tolist()
    return {
        name: {
            "width": width,
            "height": height,
            "distortion_model": name,
            "K": k,
            "D": d,
            "R": r,
            "P": p,
        }
        for name, d in [
            ("plumb_bob", [-0.29, 0.095, 0.0012, -0.0008, -0.014]),
            ("rational_polynomial", [0.52, -0.11, 0.0009, 0.0006, 0.025, 0.81, -0.07, 0.012]),
            ("equidistant", [-0.013, 0.0045, -0.0021, 0.0004]),
        ]
    }


def opencv_maps(case):
    """OpenCV's fixed-point maps (CV_16SC2, CV_16UC1) for a case."""
    k = np.array(case["K"], dtype=np.float64).reshape(3, 3)
    d = np.array(case["D"], dtype=np.float64)
    r = np.array(case["R"], dtype=np.float64).reshape(3, 3)
    p = np.array(case["P"], dtype=np.float64).reshape(3, 4)
    size = (case["width"], case["height"])
    if case["distortion_model"] == "equidistant":
        return cv2.fisheye.initUndistortRectifyMap(k, d.reshape(4, 1), r, p, size, cv2.CV_16SC2)
    return cv2.initUndistortRectifyMap(k, d, r, p, size, cv2.CV_16SC2)


def opencv_remap(image, maps, interpolation):
    m1, m2 = maps
    return cv2.remap(
        image, m1, m2, INTERPOLATIONS[interpolation], borderMode=cv2.BORDER_CONSTANT, borderValue=0
    )


def texture(width, height, channels=1, noise=True):
    """A deterministic test image: gradients and a checkerboard, with fine stripes and
    hashed noise unless `noise` is false. Without noise it is the image of the cargo
    fixture test, which computes the same formula so that it need not be stored."""
    y, x = np.mgrid[0:height, 0:width].astype(np.int64)
    planes = []
    for c in range(channels):
        checker = ((x // 8 + y // 8 + c) % 2) * 96
        stripes = ((x * 3 + y * (c + 1)) % 17) * 5 if noise else 0
        hashed = ((x * 73856093) ^ (y * 19349663) ^ (c * 83492791)) % 41 if noise else 0
        planes.append(((checker + stripes + hashed + x + y) % 256).astype(np.uint8))
    return planes[0] if channels == 1 else np.dstack(planes)


def example_binary(explicit=None):
    """Path of the remap_image example, built in release mode unless given."""
    if explicit:
        return explicit
    subprocess.run(
        ["cargo", "build", "--release", "-q", "-p", "stereocal-vision", "--example", "remap_image"],
        cwd=REPO,
        check=True,
    )
    return os.path.join(REPO, "target", "release", "examples", "remap_image")


def write_params(path, case, interpolation):
    with open(path, "w") as f:
        json.dump(dict(case, interpolation=interpolation), f)


def fail(message):
    print(message, file=sys.stderr)
    sys.exit(1)


def read_map(path, width, height):
    """Our map as positions in 1/32 pixel, shape (height, width, 2)."""
    raw = np.fromfile(path, dtype="<i2", count=width * height * 2).reshape(height, width, 2)
    fraction = np.fromfile(path, dtype="<u2", offset=width * height * 4).reshape(height, width)
    return fixed_positions(raw, fraction)


def fixed_positions(xy, fraction):
    xy = xy.astype(np.int64)
    fraction = fraction.astype(np.int64)
    return np.dstack([xy[..., 0] * 32 + (fraction & 31), xy[..., 1] * 32 + (fraction >> 5)])


def image_kinds(width, height):
    mono = texture(width, height)
    return {
        "mono8": mono,
        "rgb8": texture(width, height, 3),
        "mono16": mono.astype(np.uint16) * 257 + (texture(width, height, 2)[..., 1] % 251),
    }


PNG_SMALLEST = [cv2.IMWRITE_PNG_COMPRESSION, 9]


def write_fixture(directory):
    os.makedirs(directory, exist_ok=True)
    width, height = 160, 120
    mono = texture(width, height, noise=False)
    rgb = texture(width, height, 3, noise=False)
    for name, case in cases(width, height).items():
        with open(os.path.join(directory, f"{name}.json"), "w") as f:
            json.dump(case, f, indent=1)
        maps = opencv_maps(case)
        for interpolation in INTERPOLATIONS:
            out = opencv_remap(mono, maps, interpolation)
            cv2.imwrite(os.path.join(directory, f"{name}_{interpolation}_mono8.png"), out, PNG_SMALLEST)
        if name == "plumb_bob":
            out = opencv_remap(rgb, maps, "bilinear")
            # cv2.imwrite takes BGR: swap so that channel 0 comes first in the file.
            cv2.imwrite(os.path.join(directory, f"{name}_bilinear_rgb8.png"), out[..., ::-1], PNG_SMALLEST)
    print(f"fixture written to {directory}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin", help="path of a built remap_image example")
    parser.add_argument("--size", default="640x480", help="image size WxH")
    parser.add_argument("--fixture", help="write the cargo test fixture into this directory")
    args = parser.parse_args()
    if args.fixture:
        write_fixture(args.fixture)
        return
    width, height = (int(v) for v in args.size.split("x"))
    binary = example_binary(args.bin)
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        inputs = {}
        for kind, image in image_kinds(width, height).items():
            path = os.path.join(tmp, f"{kind}.png")
            # cv2.imwrite writes BGR order; our example reads the file's channel order.
            cv2.imwrite(path, image[..., ::-1] if image.ndim == 3 else image)
            inputs[kind] = path
        for name, case in cases(width, height).items():
            maps = opencv_maps(case)
            params = os.path.join(tmp, "params.json")
            write_params(params, case, "bilinear")
            map_path = os.path.join(tmp, "map.bin")
            subprocess.run([binary, params, inputs["mono8"], os.path.join(tmp, "o.png"), "--map", map_path], check=True)
            ours = read_map(map_path, width, height)
            theirs = fixed_positions(maps[0], maps[1])
            step_diff = np.abs(ours - theirs).max(axis=2)
            print(
                f"{name:20s} map       max {step_diff.max()}/32 px, "
                f"{np.count_nonzero(step_diff)} of {step_diff.size} positions differ"
            )
            if step_diff.max() > 1:
                failures.append(f"{name} map differs by {step_diff.max()}/32 px")
            for kind, image in image_kinds(width, height).items():
                for interpolation in INTERPOLATIONS:
                    write_params(params, case, interpolation)
                    out_path = os.path.join(tmp, "out.png")
                    subprocess.run([binary, params, inputs[kind], out_path], check=True)
                    got = cv2.imread(out_path, cv2.IMREAD_UNCHANGED)
                    if got.ndim == 3:
                        got = got[..., ::-1]
                    expected = opencv_remap(image, maps, interpolation)
                    diff = np.abs(got.astype(np.int64) - expected.astype(np.int64))
                    print(
                        f"{name:20s} {kind:6s} {interpolation:8s} max {diff.max():3d}  "
                        f"mean {diff.mean():.5f}  pixels differing {np.count_nonzero(diff.reshape(height, width, -1).any(axis=2))}"
                    )
                    if diff.max() > 1:
                        failures.append(f"{name} {kind} {interpolation} differs by {diff.max()}")
    if failures:
        fail("MISMATCH: " + "; ".join(failures))
    print("OK: stereocal matches OpenCV")


if __name__ == "__main__":
    main()
