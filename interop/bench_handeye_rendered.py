#!/usr/bin/env python3
"""The joint refinement against the classic methods on rendered hand-eye sessions.

For each setup (eye-in-hand, eye-to-hand) and target (the 9x6 chessboard of 30 mm
squares, the 10x7 ChArUco board of config/boards/charuco_10x7_40mm.yaml), --sessions
seeds of `stereocal synth` render a session of --frames frames (1024x768, the robot
reporting its poses with 0.05 degree and 0.3 mm of noise, standing still at each
frame); `stereocal handeye --image-topic ... --json` finds the target in every image,
runs every method and refines on the corners. Each result's error against the ground
truth's `tool_from_camera` (or `base_from_camera`) is taken, and printed per setup and
target: the refined result's median rotation (degrees) and translation (mm) error; the
best of the five AX = XB methods by their median (Tsai, Park, Horaud, Andreff,
Daniilidis, which give OpenCV's calibrateHandEye numbers within 1e-6 degree and 1e-6 mm
on these sessions' poses: interop/check_handeye_opencv.py); and, per session, how often
the refinement beats the best of the five on that session (an oracle that knows the
truth).

Usage: .venv/bin/python interop/bench_handeye_rendered.py
       [--stereocal target/release/stereocal] [--sessions 6] [--frames 15]
"""

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
FIVE = ("tsai", "park", "horaud", "andreff", "daniilidis")
SETUPS = (("handeye-in-hand", "eye-in-hand", "tool_from_camera"),
          ("handeye-to-hand", "eye-to-hand", "base_from_camera"))
TARGETS = {
    "chessboard": ([], ["--size", "9x6", "--square", "0.03"]),
    "charuco": (["--board", str(ROOT / "config" / "boards" / "charuco_10x7_40mm.yaml")],
                ["--pattern", "charuco", "--size", "10x7", "--square", "0.04",
                 "--charuco_marker_size", "0.03", "--aruco_dict", "5x5_100"]),
}


def error(transform, truth):
    """(degrees, mm) between a `--json` transform and a ground-truth record."""
    rotation = np.reshape(transform["rotation"], (3, 3))
    angle, _ = cv2.Rodrigues(rotation @ np.reshape(truth["rotation_row_major"], (3, 3)).T)
    offset = np.subtract(transform["translation"], truth["translation_m"])
    return float(np.degrees(np.linalg.norm(angle))), float(np.linalg.norm(offset) * 1e3)


def session(stereocal, out, scene, setup, key, target, seed, frames):
    """Every method's (degrees, mm) error on one rendered session."""
    synth_args, handeye_args = TARGETS[target]
    subprocess.run([stereocal, "synth", "--scene", scene, "--seed", str(seed), "--frames",
                    str(frames), "--out", str(out), *synth_args], check=True,
                   capture_output=True)
    truth = json.loads((out / "ground_truth.json").read_text())["extrinsics"][key]
    run = subprocess.run([stereocal, "handeye", "--bag", str(out / "bag"), "--setup", setup,
                          "--image-topic", "/camera/image_raw", "--robot-pose-topic",
                          "/robot/tool_pose", "--out", str(out / "handeye"), "--json",
                          *handeye_args], capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"stereocal handeye failed on {out}:\n{run.stderr[-2000:]}")
    results = json.loads(run.stdout)["results"]
    return {method: error(t, truth) for method, t in results.items()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stereocal", default=str(ROOT / "target" / "release" / "stereocal"))
    parser.add_argument("--sessions", type=int, default=6)
    parser.add_argument("--frames", type=int, default=15)
    args = parser.parse_args()
    print(f"{args.sessions} rendered sessions of {args.frames} frames per row; median errors")
    print(f"{'setup':12} {'target':11} {'refined':>20} {'best of the five by median':>40} "
          f"{'refined beats the per-session best':>36}")
    with tempfile.TemporaryDirectory() as tmp:
        for scene, setup, key in SETUPS:
            for target in TARGETS:
                errors = [session(args.stereocal, Path(tmp) / f"{scene}-{target}-{seed}", scene,
                                  setup, key, target, seed, args.frames)
                          for seed in range(1, args.sessions + 1)]
                median = {m: np.median([e[m] for e in errors], axis=0) for m in errors[0]}
                best_rotation = min(FIVE, key=lambda m: median[m][0])
                best_translation = min(FIVE, key=lambda m: median[m][1])
                rotation_wins = sum(e["refined"][0] < min(e[m][0] for m in FIVE) for e in errors)
                translation_wins = sum(e["refined"][1] < min(e[m][1] for m in FIVE)
                                       for e in errors)
                refined = median["refined"]
                print(f"{setup:12} {target:11} {refined[0]:7.4f} deg {refined[1]:6.3f} mm "
                      f"{best_rotation:>10} {median[best_rotation][0]:.4f} deg, "
                      f"{best_translation:>10} {median[best_translation][1]:.3f} mm "
                      f"{rotation_wins:>10}/{len(errors)} rot, {translation_wins}/{len(errors)} mm")


if __name__ == "__main__":
    main()
