"""Times stereocal's map building and remap against OpenCV's on the same 1920x1080 image
and the same camera (plumb_bob with a rectification R and a new projection P, from
check_remap_opencv.py), one thread and all threads, side by side in one run.

    .venv/bin/python interop/bench_remap_opencv.py [--bin PATH] [--iterations 100] [--rounds 3]
        [--map-models plumb_bob,rational_polynomial,equidistant]

stereocal runs through the `remap_image` example in its timing mode (`--bench N`), which
builds the fixed-point map N times and remaps N times into a reused output, on one
thread (`--threads 1`) or all threads. OpenCV builds its fixed-point maps
(initUndistortRectifyMap, CV_16SC2 + CV_16UC1) N times into preallocated arrays and
remaps into a preallocated `dst`, with cv2.setNumThreads(1) and with its default thread
count. `--map-models` times map building for the other cameras of check_remap_opencv.py
too. Rounds alternate between the two sides so that load from other processes hits both
alike. Prints the minimum and median times in milliseconds and the ratio OpenCV /
stereocal of the minima and of the medians (above 1: stereocal is faster).
"""

import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time

import cv2
import numpy as np

from check_remap_opencv import INTERPOLATIONS, cases, example_binary, opencv_maps, texture, write_params

WIDTH, HEIGHT = 1920, 1080


def time_opencv(image, maps, interpolation, iterations):
    dst = cv2.remap(image, maps[0], maps[1], INTERPOLATIONS[interpolation], borderMode=cv2.BORDER_CONSTANT)
    times = []
    for _ in range(iterations):
        start = time.perf_counter()
        cv2.remap(
            image, maps[0], maps[1], INTERPOLATIONS[interpolation], dst=dst, borderMode=cv2.BORDER_CONSTANT
        )
        times.append((time.perf_counter() - start) * 1e3)
    return times


def time_opencv_maps(case, iterations):
    """initUndistortRectifyMap (fisheye.initUndistortRectifyMap for equidistant) into
    preallocated maps: OpenCV's fastest way to build them, without the fresh pages that
    new output arrays sometimes cost."""
    k = np.array(case["K"], dtype=np.float64).reshape(3, 3)
    d = np.array(case["D"], dtype=np.float64)
    r = np.array(case["R"], dtype=np.float64).reshape(3, 3)
    p = np.array(case["P"], dtype=np.float64).reshape(3, 4)
    size = (case["width"], case["height"])
    map1 = np.empty((case["height"], case["width"], 2), np.int16)
    map2 = np.empty((case["height"], case["width"]), np.uint16)
    times = []
    if case["distortion_model"] == "equidistant":
        d = d.reshape(4, 1)
        build = cv2.fisheye.initUndistortRectifyMap
    else:
        build = cv2.initUndistortRectifyMap
    for _ in range(iterations):
        start = time.perf_counter()
        build(k, d, r, p, size, cv2.CV_16SC2, map1, map2)
        times.append((time.perf_counter() - start) * 1e3)
    return times


def time_ours(binary, params, image_path, iterations, threads):
    out = subprocess.run(
        [binary, params, image_path, "--bench", str(iterations), "--threads", threads],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return json.loads(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bin", help="path of a built remap_image example (release)")
    parser.add_argument("--iterations", type=int, default=100)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--map-models",
        default="plumb_bob",
        help="comma-separated distortion models whose map building is timed "
        "(plumb_bob, rational_polynomial, equidistant); the remaps use plumb_bob",
    )
    args = parser.parse_args()
    binary = example_binary(args.bin)
    all_cases = cases(WIDTH, HEIGHT)
    case = all_cases["plumb_bob"]
    default_threads = cv2.getNumThreads()
    print(f"OpenCV {cv2.__version__}, default threads {default_threads}, cpus {os.cpu_count()}")
    print(
        f"{'case':40s} {'OpenCV min/median':>20s} {'stereocal min/median':>22s}"
        f" {'ratio min':>10s} {'ratio median':>13s}"
    )
    thread_settings = [("1 thread", 1, "1"), ("all threads", default_threads, "all")]

    def report(name, cv_times, our_min, our_median):
        cv_min, cv_median = min(cv_times), statistics.median(cv_times)
        ours_min, ours_median = min(our_min), statistics.median(our_median)
        print(
            f"{name:40s} {cv_min:9.3f} /{cv_median:8.3f}  {ours_min:10.3f} /{ours_median:8.3f}"
            f"  {cv_min / ours_min:9.2f}x {cv_median / ours_median:12.2f}x"
        )

    with tempfile.TemporaryDirectory() as tmp:
        params = os.path.join(tmp, "params.json")
        images = {}
        for kind, channels in [("mono8", 1), ("rgb8", 3)]:
            image = texture(WIDTH, HEIGHT, channels)
            images[kind] = (image, os.path.join(tmp, f"{kind}.png"))
            cv2.imwrite(images[kind][1], image if channels == 1 else image[..., ::-1])
        # Map building: N fixed-point maps per round on each side.
        for model in args.map_models.split(","):
            map_case = all_cases[model]
            write_params(params, map_case, "bilinear")
            for threads_name, cv_threads, our_threads in thread_settings:
                cv_times, our_min, our_median = [], [], []
                for _ in range(args.rounds):
                    cv2.setNumThreads(cv_threads)
                    cv_times += time_opencv_maps(map_case, args.iterations)
                    ours = time_ours(binary, params, images["mono8"][1], args.iterations, our_threads)
                    our_min.append(ours["map_ms_min"])
                    our_median.append(ours["map_ms_median"])
                report(f"map build {model} {threads_name}", cv_times, our_min, our_median)
        # Remap with one map, built once per side.
        for kind, (image, image_path) in images.items():
            for interpolation in ["bilinear", "nearest"]:
                write_params(params, case, interpolation)
                for threads_name, cv_threads, our_threads in thread_settings:
                    cv_times, our_min, our_median = [], [], []
                    for _ in range(args.rounds):
                        cv2.setNumThreads(cv_threads)
                        maps = opencv_maps(case)
                        cv_times += time_opencv(image, maps, interpolation, args.iterations)
                        ours = time_ours(binary, params, image_path, args.iterations, our_threads)
                        our_min.append(ours["remap_ms_min"])
                        our_median.append(ours["remap_ms_median"])
                    report(f"remap {kind} {interpolation} {threads_name}", cv_times, our_min, our_median)
        cv2.setNumThreads(default_threads)

if __name__ == "__main__":
    main()
