#!/usr/bin/env python3
"""PnP speed, stereocal's `estimate_pose` against cv2.solvePnP, side by side in one run.

The problems: a 9x6 board of 30 mm squares (planar), and the same 54 points spread in
depth by up to +-5 cm (general), each at --poses random poses in front of a plumb_bob
camera (1024x768, fx 800, fy 805, cx 515, cy 380, D [-0.25, 0.08, 0.001, -0.0005, 0]),
every point in the image, projected by cv2.projectPoints with Gaussian noise of 0.2 px.
They are written as JSON and timed, per call, from the pixels (cv2.solvePnP takes
pixels and undistorts inside; so does ours: `Correspondences::new` + `estimate_pose`,
the `pnp_timing` example):
- stereocal, one thread;
- cv2.solvePnP with cv2.setNumThreads(1): SOLVEPNP_SQPNP and SOLVEPNP_ITERATIVE, and
  for the board SOLVEPNP_EPNP and SOLVEPNP_IPPE.
Each problem is timed in batches of --calls calls; its time is the median over
--repeats batches. Rounds of OpenCV then stereocal (--rounds) weigh a change of the
machine's load on both; the medians over the rounds are compared. Printed per kind of
problem: the median over the poses of the time per call, and the ratio OpenCV time /
stereocal time (above 1, stereocal is faster); and, as a check that both solved the
same problems, the largest rotation between our pose and ITERATIVE's.

Note what each call does: ours refines on the pixel error through the full camera
model and judges the pose (planar ambiguity, covariance), ITERATIVE refines too
(Levenberg-Marquardt), SQPNP, EPNP and IPPE do not refine.

Usage: .venv/bin/python interop/bench_pnp_opencv.py
       [--example target/release/examples/pnp_timing] [--poses 8] [--calls 200]
       [--repeats 7] [--rounds 3] [--seed 1]
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

REPO = Path(__file__).resolve().parent.parent
WIDTH, HEIGHT = 1024, 768
K = np.array([[800.0, 0.0, 515.0], [0.0, 805.0, 380.0], [0.0, 0.0, 1.0]])
D = np.array([-0.25, 0.08, 0.001, -0.0005, 0.0])
NOISE_PX = 0.2
METHODS = {
    "board": ("SQPNP", "ITERATIVE", "EPNP", "IPPE"),
    "spatial": ("SQPNP", "ITERATIVE"),
}
FLAGS = {"SQPNP": cv2.SOLVEPNP_SQPNP, "ITERATIVE": cv2.SOLVEPNP_ITERATIVE,
         "EPNP": cv2.SOLVEPNP_EPNP, "IPPE": cv2.SOLVEPNP_IPPE}


def board_points(rng, depth):
    """The 9x6 grid of 30 mm squares, each point moved off the plane by up to `depth`."""
    grid = np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 0.03
    z = rng.uniform(-depth, depth, len(grid)) if depth else np.zeros(len(grid))
    return np.column_stack([grid, z])


def random_pose(rng, points):
    """A pose that puts every point 0.35 to 1.2 m in front of the camera and in the image
    with a margin, the target turned up to about 45 degrees from facing the camera."""
    centre = points.mean(axis=0)
    while True:
        axis = rng.normal(size=3)
        rvec = axis / np.linalg.norm(axis) * rng.uniform(0.0, 0.8)
        rotation = cv2.Rodrigues(rvec)[0]
        # Half a turn about x: the board faces the camera.
        rotation = rotation @ np.diag([1.0, -1.0, -1.0])
        distance = rng.uniform(0.35, 1.2)
        aim = np.array([rng.uniform(-0.25, 0.25), rng.uniform(-0.2, 0.2), 1.0]) * distance
        tvec = aim - rotation @ centre
        in_camera = points @ rotation.T + tvec
        if np.any(in_camera[:, 2] <= 0.1):
            continue
        pixels = project(points, rotation, tvec)
        if (pixels[:, 0].min() > 20 and pixels[:, 0].max() < WIDTH - 20
                and pixels[:, 1].min() > 20 and pixels[:, 1].max() < HEIGHT - 20):
            return rotation, tvec


def project(points, rotation, tvec):
    pixels, _ = cv2.projectPoints(points, cv2.Rodrigues(rotation)[0], tvec, K, D)
    return pixels.reshape(-1, 2)


def problems(poses, seed):
    rng = np.random.default_rng(seed)
    out = []
    for kind, depth in (("board", 0.0), ("spatial", 0.05)):
        points = board_points(rng, depth)
        for index in range(poses):
            rotation, tvec = random_pose(rng, points)
            pixels = project(points, rotation, tvec) + rng.normal(0.0, NOISE_PX, (len(points), 2))
            out.append({"name": f"{kind}_{index}", "kind": kind, "target_points": points.tolist(),
                        "pixels": pixels.tolist(),
                        "truth": {"rotation": rotation.ravel().tolist(), "translation": tvec.tolist()}})
    return out


def opencv_times(items, calls, repeats):
    """{(problem, method): median seconds per call over `repeats` batches of `calls`}."""
    cv2.setNumThreads(1)
    times = {}
    for item in items:
        points = np.array(item["target_points"])
        pixels = np.array(item["pixels"])
        for method in METHODS[item["kind"]]:
            flag = FLAGS[method]
            batches = []
            for batch in range(repeats + 1):
                start = time.perf_counter()
                for _ in range(calls):
                    cv2.solvePnP(points, pixels, K, D, flags=flag)
                if batch:
                    batches.append((time.perf_counter() - start) / calls)
            times[(item["name"], method)] = statistics.median(batches)
    cv2.setNumThreads(0)
    return times


def rotation_angle_degrees(r):
    """The angle of a rotation matrix, degrees; accurate near zero, where cv2.Rodrigues
    returns a zero vector for angles below about 1e-5 rad."""
    skew = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return float(np.degrees(np.arctan2(np.linalg.norm(skew) / 2, (np.trace(r) - 1) / 2)))


def rotation_between_degrees(a, b):
    return rotation_angle_degrees(np.asarray(a).reshape(3, 3) @ np.asarray(b).reshape(3, 3).T)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--example", type=Path,
                        default=REPO / "target" / "release" / "examples" / "pnp_timing")
    parser.add_argument("--poses", type=int, default=8)
    parser.add_argument("--calls", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    if not args.example.exists():
        sys.exit(f"{args.example} is missing: cargo build --release -p stereocal-vision --example pnp_timing")

    items = problems(args.poses, args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "problems.json"
        camera = {"width": WIDTH, "height": HEIGHT, "fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2],
                  "cy": K[1, 2], "distortion_model": "plumb_bob", "distortion_coefficients": D.tolist()}
        path.write_text(json.dumps({"camera": camera, "problems": items}))
        rounds_cv, rounds_ours = [], []
        for _ in range(args.rounds):
            rounds_cv.append(opencv_times(items, args.calls, args.repeats))
            done = subprocess.run([str(args.example), str(path), "--calls", str(args.calls),
                                   "--repeats", str(args.repeats)], capture_output=True, text=True)
            if done.returncode != 0:
                sys.exit(f"pnp_timing failed:\n{done.stderr}")
            rounds_ours.append(json.loads(done.stdout))

    ours = {p["name"]: p for p in rounds_ours[-1]["problems"]}
    our_seconds = {name: statistics.median(
        next(p["seconds"] for p in r["problems"] if p["name"] == name) for r in rounds_ours)
        for name in ours}
    cv_seconds = {key: statistics.median(r[key] for r in rounds_cv) for key in rounds_cv[0]}

    print(f"OpenCV {cv2.__version__}; 54 points, {args.poses} poses per kind, {NOISE_PX} px noise; "
          f"one thread each; median over {args.repeats} batches of {args.calls} calls, "
          f"medians over {args.rounds} rounds; microseconds per call")
    failures = []
    for kind in METHODS:
        names = [item["name"] for item in items if item["kind"] == kind]
        mine = statistics.median(our_seconds[n] for n in names)
        print(f"\n{kind} (54 points{', on a plane' if kind == 'board' else ', +-5 cm in depth'})")
        print(f"    stereocal estimate_pose     {mine * 1e6:8.1f}")
        for method in METHODS[kind]:
            theirs = statistics.median(cv_seconds[(n, method)] for n in names)
            print(f"    cv2.solvePnP {method:14} {theirs * 1e6:8.1f}   ratio {theirs / mine:5.2f}x")
        # Both must have solved the same problems: our pose against ITERATIVE's.
        worst = 0.0
        for item in (i for i in items if i["kind"] == kind):
            _, rvec, _ = cv2.solvePnP(np.array(item["target_points"]), np.array(item["pixels"]), K, D,
                                      flags=cv2.SOLVEPNP_ITERATIVE)
            worst = max(worst, rotation_between_degrees(
                ours[item["name"]]["camera_from_target"]["rotation"], cv2.Rodrigues(rvec)[0]))
        print(f"    largest rotation between our pose and ITERATIVE's: {worst:.2e} deg")
        if worst > 1e-3:
            failures.append(f"{kind}: our pose and ITERATIVE's differ by {worst:.3g} deg")
    for failure in failures:
        print("MISMATCH:", failure)
    if failures:
        sys.exit(1)


if __name__ == "__main__":
    main()
