"""Times stereocal's remap and map building against OpenCV's on the same 1920x1080 image
and the same camera (plumb_bob with a rectification R and a new projection P, from
check_remap_opencv.py), one thread and all threads, side by side in one run.

    .venv/bin/python interop/bench_remap_opencv.py [--bin PATH] [--iterations 100] [--rounds 3]

stereocal runs through the `remap_image` example in its timing mode (`--bench N`), which
builds the map once and times N remaps into a reused output; OpenCV remaps into a
preallocated `dst` with its fixed-point maps (CV_16SC2 + CV_16UC1), with
cv2.setNumThreads(1) and with its default thread count. Rounds alternate between the two
so that load from other processes hits both alike. Prints the minimum and median times
in milliseconds and the ratio OpenCV / stereocal (above 1: stereocal is faster).
"""

import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time

import cv2

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
    args = parser.parse_args()
    binary = example_binary(args.bin)
    case = cases(WIDTH, HEIGHT)["plumb_bob"]
    default_threads = cv2.getNumThreads()
    print(f"OpenCV {cv2.__version__}, default threads {default_threads}, cpus {os.cpu_count()}")
    print(f"{'case':32s} {'OpenCV min/median':>20s} {'stereocal min/median':>22s} {'ratio min':>10s}")
    with tempfile.TemporaryDirectory() as tmp:
        params = os.path.join(tmp, "params.json")
        # Map building.
        cv_map_ms, our_map_ms = [], []
        for kind, channels in [("mono8", 1), ("rgb8", 3)]:
            image = texture(WIDTH, HEIGHT, channels)
            image_path = os.path.join(tmp, f"{kind}.png")
            cv2.imwrite(image_path, image if channels == 1 else image[..., ::-1])
            for interpolation in ["bilinear", "nearest"]:
                write_params(params, case, interpolation)
                for threads_name, cv_threads, our_threads in [
                    ("1 thread", 1, "1"),
                    ("all threads", default_threads, "all"),
                ]:
                    cv_times, our_min, our_median = [], [], []
                    for _ in range(args.rounds):
                        cv2.setNumThreads(cv_threads)
                        start = time.perf_counter()
                        maps = opencv_maps(case)
                        if our_threads == "all":
                            cv_map_ms.append((time.perf_counter() - start) * 1e3)
                        cv_times += time_opencv(image, maps, interpolation, args.iterations)
                        ours = time_ours(binary, params, image_path, args.iterations, our_threads)
                        our_min.append(ours["remap_ms_min"])
                        our_median.append(ours["remap_ms_median"])
                        if our_threads == "all":
                            our_map_ms.append(ours["map_ms"])
                    cv_min, cv_median = min(cv_times), statistics.median(cv_times)
                    ours_min, ours_median = min(our_min), statistics.median(our_median)
                    name = f"remap {kind} {interpolation} {threads_name}"
                    print(
                        f"{name:32s} {cv_min:9.3f} /{cv_median:8.3f}  {ours_min:10.3f} /{ours_median:8.3f}"
                        f"  {cv_min / ours_min:9.2f}x"
                    )
        cv2.setNumThreads(default_threads)
        print(
            f"{'map build, all threads':32s} {min(cv_map_ms):9.3f} /{statistics.median(cv_map_ms):8.3f}"
            f"  {min(our_map_ms):10.3f} /{statistics.median(our_map_ms):8.3f}"
            f"  {min(cv_map_ms) / min(our_map_ms):9.2f}x"
        )


if __name__ == "__main__":
    main()
