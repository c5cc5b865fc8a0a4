#!/usr/bin/env python3
"""Dense stereo: stereocal's semi-global matcher against OpenCV's StereoSGBM, side by side
on the same rectified pairs in one run, scored against the exact truth of `stereocal synth`.

The pairs (`stereocal synth --scene depth`): rooms of boxes, a slanted board, a floor,
thin poles and a weakly textured panel before a wall, rendered at 640x480 (f 600 px,
9 cm baseline, the webcams of the stereo depth report) and at 1280x720, with defocus,
sensor noise and a right camera 4 % brighter plus 2 grey levels. Both matchers search
128 disparities from 0.

OpenCV: `cv2.StereoSGBM_create` in its default mode (five paths) and MODE_SGBM_3WAY, at
block sizes 3 and 5, with the P1 = 8 * bs^2 and P2 = 32 * bs^2 its documentation
recommends for one channel, uniquenessRatio 10, disp12MaxDiff 1, speckleWindowSize 100,
speckleRange 2. stereocal: `SgmParams` defaults (`--paths` to change the path count,
`--refine-radius` the refinement's window).

Scores, over the pixels the right camera also sees (non-occluded), per frame then
averaged over frames:
- bad-1.0 and bad-2.0: fraction off the truth by more than 1 or 2 px, invalid pixels
  counted as errors;
- EPE: mean absolute error of the valid pixels;
- density: fraction of non-occluded pixels with a disparity.
Checked: stereocal is better than every OpenCV configuration on all three errors.

Speed: each pair is matched --repeats times after one untimed run; a pair's time is
the median. Rounds (--rounds) of OpenCV then stereocal weigh changes of the machine's
load on both. With one thread (cv2.setNumThreads(1), `--threads 1`) and with all. The
ratio OpenCV time / stereocal time is printed (above 1, stereocal is faster); with
--check-speed the script fails when a ratio against SGBM or 3WAY is below 1.

The walls (`stereocal synth --scene depth-walls`, 640x480, 0.3 to 3 m, 192
disparities): per distance, the 95th percentile of the relative depth error |Z - Z_true|
/ Z_true over the wall (invalid pixels counted as errors), beside the theoretical
relative error dZ / Z = Z * dd / (f * B) (from dZ = Z^2 * dd / (f * B)) for the 95th
percentile of stereocal's disparity error dd.

Usage: .venv/bin/python interop/bench_depth_opencv.py
       [--stereocal target/release/stereocal]
       [--timing target/release/examples/stereo_timing] [--frames 3] [--repeats 5]
       [--rounds 2] [--paths eight] [--refine-radius 4] [--check-speed] [--skip-walls]
       [--skip-720p] [--skip-bm | --bm-only]

Block matching: stereocal's `BlockMatcher` and cv2.StereoBM with stereo_image_proc's
defaults (window 15, prefilter_cap 31, texture_threshold 10, uniqueness_ratio 15,
speckle 100 / 4), scored and timed the same way on the 640x480 pairs.
"""

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bag_images import grey_images  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
RANGE = 128
WALL_RANGE = 192


def read_pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"Pf", f"{path}: not a grey PFM"
        width, height = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    return np.flipud(data.reshape(height, width)).copy()


def synth(stereocal, out, args):
    subprocess.run([stereocal, "synth", "--out", str(out), *args], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    truth = json.loads((out / "depth_truth.json").read_text())
    lefts = [img for _, _, img in grey_images(out / "bag", ["/stereo/left/image_rect"])]
    rights = [img for _, _, img in grey_images(out / "bag", ["/stereo/right/image_rect"])]
    frames = []
    for record, left, right in zip(truth["frames"], lefts, rights):
        disparity = read_pfm(out / record["disparity"])
        visible = cv2.imread(str(out / record["visible"]), cv2.IMREAD_GRAYSCALE) > 0
        frames.append({"left": left, "right": right, "truth": disparity,
                       "visible": visible & np.isfinite(disparity), "record": record})
    return truth, frames


def score(disparity, frame):
    mask = frame["visible"]
    truth = frame["truth"][mask]
    found = disparity[mask]
    valid = np.isfinite(found)
    error = np.where(valid, np.abs(found - truth), np.inf)
    return {
        "bad1": float(np.mean(error > 1.0)),
        "bad2": float(np.mean(error > 2.0)),
        "epe": float(np.mean(error[valid])) if valid.any() else float("inf"),
        "density": float(np.mean(valid)),
    }


def opencv_matcher(mode, block, disparities):
    return cv2.StereoSGBM_create(
        minDisparity=0, numDisparities=disparities, blockSize=block,
        P1=8 * block * block, P2=32 * block * block, disp12MaxDiff=1,
        uniquenessRatio=10, speckleWindowSize=100, speckleRange=2, mode=mode)


def opencv_disparity(matcher, frame):
    raw = matcher.compute(frame["left"], frame["right"]).astype(np.float32) / 16.0
    raw[raw < 0] = np.nan
    return raw


def time_opencv(matcher, frames, repeats):
    times = []
    for frame in frames:
        matcher.compute(frame["left"], frame["right"])
        samples = []
        for _ in range(repeats):
            start = time.perf_counter()
            matcher.compute(frame["left"], frame["right"])
            samples.append((time.perf_counter() - start) * 1e3)
        times.append(statistics.median(samples))
    return statistics.median(times)


def run_ours(timing, frames, work, params, repeats, threads, algorithm="sgm"):
    pairs = []
    for i, frame in enumerate(frames):
        left, right = work / f"pair_{i}_left.png", work / f"pair_{i}_right.png"
        cv2.imwrite(str(left), frame["left"])
        cv2.imwrite(str(right), frame["right"])
        pairs.append({"left": str(left), "right": str(right), "out": str(work / f"pair_{i}.pfm")})
    spec = work / "pairs.json"
    spec.write_text(json.dumps({"algorithm": algorithm, "params": params, "pairs": pairs}))
    command = [timing, str(spec), "--repeats", str(repeats)]
    if threads:
        command += ["--threads", str(threads)]
    report = json.loads(subprocess.run(command, check=True, capture_output=True, text=True).stdout)
    disparities = [read_pfm(p["out"]) for p in pairs]
    return disparities, statistics.median(p["median_ms"] for p in report["pairs"])


def default_params(paths, disparities, refine_radius=4):
    return {"min_disparity": 0, "disparity_range": disparities, "paths": paths, "p1": 10,
            "p2": 120, "uniqueness_ratio": 5, "disp12_max_diff": 1, "speckle_size": 100,
            "speckle_range": 2.0, "refine_radius": refine_radius}


def mean_scores(scores):
    return {k: statistics.mean(s[k] for s in scores) for k in scores[0]}


def compare(name, frames, args, work):
    print(f"\n== {name}: {len(frames)} pairs of {frames[0]['left'].shape[1]}x{frames[0]['left'].shape[0]}, "
          f"{RANGE} disparities")
    params = default_params(args.paths, RANGE, args.refine_radius)
    configs = {f"OpenCV {label} bs{block}": opencv_matcher(mode, block, RANGE)
               for label, mode in (("SGBM", cv2.STEREO_SGBM_MODE_SGBM),
                                   ("3WAY", cv2.STEREO_SGBM_MODE_SGBM_3WAY))
               for block in (3, 5)}
    ours, _ = run_ours(args.timing, frames, work, params, 1, 0)
    results = {"stereocal": mean_scores([score(d, f) for d, f in zip(ours, frames)])}
    for label, matcher in configs.items():
        results[label] = mean_scores([score(opencv_disparity(matcher, f), f) for f in frames])
    print(f"{'':22} {'bad-1.0':>8} {'bad-2.0':>8} {'EPE px':>8} {'density':>8}")
    for label, s in results.items():
        print(f"{label:22} {s['bad1']:8.4f} {s['bad2']:8.4f} {s['epe']:8.3f} {s['density']:8.3f}")
    failures = []
    for label, s in results.items():
        if label == "stereocal":
            continue
        for key in ("bad1", "bad2", "epe"):
            if not results["stereocal"][key] < s[key]:
                failures.append(f"{name}: stereocal {key} {results['stereocal'][key]:.4f} is not below {label}'s {s[key]:.4f}")

    print(f"{'speed (median ms per pair)':34} {'1 thread':>10} {'all threads':>12}")
    timings = {}
    for threads in (1, 0):
        cv2.setNumThreads(threads if threads else -1)
        rounds = {label: [] for label in list(configs) + ["stereocal"]}
        for _ in range(args.rounds):
            for label, matcher in configs.items():
                rounds[label].append(time_opencv(matcher, frames, args.repeats))
            rounds["stereocal"].append(run_ours(args.timing, frames, work, params, args.repeats, threads)[1])
        for label, values in rounds.items():
            timings.setdefault(label, {})[threads] = statistics.median(values)
    for label, t in timings.items():
        print(f"{label:34} {t[1]:10.1f} {t[0]:12.1f}")
    for label, t in timings.items():
        if label == "stereocal":
            continue
        ratios = [t[threads] / timings["stereocal"][threads] for threads in (1, 0)]
        print(f"ratio {label} / stereocal: 1 thread {ratios[0]:.2f}x, all threads {ratios[1]:.2f}x")
        if args.check_speed and min(ratios) < 1.0:
            failures.append(f"{name}: {label} is faster than stereocal ({ratios[0]:.2f}x, {ratios[1]:.2f}x)")
    return failures


def bm_params(disparities):
    """stereo_image_proc's block-matching defaults (window 15, prefilter_cap 31,
    texture_threshold 10, uniqueness_ratio 15, speckle 100 / 4), left-right check off."""
    return {"min_disparity": 0, "disparity_range": disparities, "window": 15, "prefilter_cap": 31,
            "texture_threshold": 10, "uniqueness_ratio": 15, "disp12_max_diff": None,
            "speckle_size": 100, "speckle_range": 4.0}


def opencv_bm(disparities):
    """cv2.StereoBM with the same parameters as `bm_params`, as stereo_image_proc sets them."""
    matcher = cv2.StereoBM_create(numDisparities=disparities, blockSize=15)
    matcher.setPreFilterCap(31)
    matcher.setTextureThreshold(10)
    matcher.setUniquenessRatio(15)
    matcher.setSpeckleWindowSize(100)
    matcher.setSpeckleRange(4)
    matcher.setDisp12MaxDiff(-1)
    return matcher


def compare_bm(name, frames, args, work):
    """Block matching: stereocal's BlockMatcher against cv2.StereoBM, the same parameters;
    accuracy and speed printed (no check: BM is the cheap mode, scored for information)."""
    print(f"\n== block matching, {name}: {len(frames)} pairs, {RANGE} disparities, window 15")
    params = bm_params(RANGE)
    matcher = opencv_bm(RANGE)
    ours, _ = run_ours(args.timing, frames, work, params, 1, 0, "bm")
    results = {"stereocal BM": mean_scores([score(d, f) for d, f in zip(ours, frames)]),
               "OpenCV StereoBM": mean_scores([score(opencv_disparity(matcher, f), f) for f in frames])}
    print(f"{'':22} {'bad-1.0':>8} {'bad-2.0':>8} {'EPE px':>8} {'density':>8}")
    for label, s in results.items():
        print(f"{label:22} {s['bad1']:8.4f} {s['bad2']:8.4f} {s['epe']:8.3f} {s['density']:8.3f}")
    print(f"{'speed (median ms per pair)':34} {'1 thread':>10} {'all threads':>12}")
    for threads in (1, 0):
        cv2.setNumThreads(threads if threads else -1)
        theirs, mine = [], []
        for _ in range(args.rounds):
            theirs.append(time_opencv(matcher, frames, args.repeats))
            mine.append(run_ours(args.timing, frames, work, params, args.repeats, threads, "bm")[1])
        theirs, mine = statistics.median(theirs), statistics.median(mine)
        print(f"{'threads ' + (str(threads) if threads else 'all'):34} OpenCV {theirs:8.1f}  stereocal "
              f"{mine:8.1f}  ratio {theirs / mine:.2f}x")
    return []


def walls(args, work):
    truth, frames = synth(args.stereocal, work / "walls", ["--scene", "depth-walls"])
    params = default_params(args.paths, WALL_RANGE, args.refine_radius)
    ours, _ = run_ours(args.timing, frames, work, params, 1, 0)
    focal, baseline = truth["focal"], truth["baseline"]
    print(f"\n== depth against distance: a textured wall, f {focal} px, baseline {baseline} m, {WALL_RANGE} disparities")
    print(f"{'Z m':>6} {'P95 |dZ|/Z':>11} {'P95 |dd| px':>12} {'theory Z*dd/(fB)':>17} {'density':>8}")
    failures = []
    for disparity, frame in zip(ours, frames):
        z_true = frame["record"]["distance"]
        mask = frame["visible"]
        found = disparity[mask]
        depth = np.where(np.isfinite(found) & (found > 0), focal * baseline / np.maximum(found, 1e-9), np.inf)
        relative = np.abs(depth - z_true) / z_true
        p95 = float(np.percentile(relative, 95))
        dd = np.abs(np.where(np.isfinite(found), found, np.inf) - frame["truth"][mask])
        p95_dd = float(np.percentile(dd, 95))
        theory = z_true * p95_dd / (focal * baseline)
        print(f"{z_true:6.2f} {p95:11.4f} {p95_dd:12.3f} {theory:17.4f} {np.mean(np.isfinite(found)):8.3f}")
        if not p95 <= 0.01:
            failures.append(f"wall at {z_true} m: P95 relative depth error {p95:.4f} above 1 %")
    return failures


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--stereocal", default=str(REPO / "target/release/stereocal"))
    parser.add_argument("--timing", default=str(REPO / "target/release/examples/stereo_timing"))
    parser.add_argument("--frames", type=int, default=3)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--paths", default="eight", choices=["four", "five", "eight"])
    parser.add_argument("--refine-radius", type=int, default=4,
                        help="SgmParams::refine_radius; 0 keeps the parabola's vertex")
    parser.add_argument("--check-speed", action="store_true")
    parser.add_argument("--skip-walls", action="store_true")
    parser.add_argument("--skip-720p", action="store_true")
    parser.add_argument("--skip-bm", action="store_true")
    parser.add_argument("--bm-only", action="store_true", help="only the 640x480 block-matching comparison")
    args = parser.parse_args()

    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        _, frames = synth(args.stereocal, work / "vga", ["--scene", "depth", "--frames", str(args.frames)])
        if args.bm_only:
            compare_bm("640x480", frames, args, work)
            return
        failures += compare("640x480", frames, args, work)
        if not args.skip_bm:
            failures += compare_bm("640x480", frames, args, work)
        if not args.skip_720p:
            _, frames = synth(args.stereocal, work / "hd", ["--scene", "depth", "--frames", str(args.frames),
                                                           "--width", "1280", "--height", "720"])
            failures += compare("1280x720", frames, args, work)
        if not args.skip_walls:
            failures += walls(args, work)
    for failure in failures:
        print("FAIL:", failure)
    if failures:
        sys.exit(1)
    print("\ndepth: all checks passed")


if __name__ == "__main__":
    main()
