#!/usr/bin/env python3
"""Hand-eye calibration, stereocal's `vision::handeye` against OpenCV's
`calibrateHandEye` (Tsai, Park, Horaud, Andreff, Daniilidis) and
`calibrateRobotWorldHandEye` (Shah, Li) on the same samples.

The samples follow OpenCV's own test protocol (calib3d test_calibration_hand_eye.cpp):
10 robot poses per session, rotations drawn as a random, unnormalized direction
(components uniform in [-1, 1]) times an angle of random sign, translations per
component; the hand-eye transform turned 10 to 50 degrees, the target's pose 5 to 85,
each robot pose 5 to 45. Eye-in-hand and eye-to-hand sessions; OpenCV solves
eye-to-hand by being given base_from_tool inverted, as its documentation says, and we
are given the robot's poses as they are.
- exact sessions (--exact of each setup): every method of ours recovers the truth
  within 1e-9 (rad and m);
- noisy sessions (--trials of each setup): Gaussian noise of 0.002 rad on each rotation
  vector component and 5 mm on each translation component of camera_from_target, and
  0.001 rad and 1 mm on base_from_tool (OpenCV's magnitudes).

With --stereocal BIN, also the command on bags: `stereocal synth` renders an eye-in-hand
and an eye-to-hand session (15 frames, the robot's poses with an arm's noise), `stereocal
pose` adds the target's poses, and `stereocal handeye --target-pose-topic ... --json`
calibrates; the bag's target and robot poses, read independently with rosbags and paired
by stamp, go to OpenCV, and every method of the command must give OpenCV's same
method's numbers (within 1e-6 degree and 1e-6 mm) on the samples it kept.

Exits non-zero when, on the noisy sessions:
- a method of ours differs from OpenCV's same method by more than 1e-6 degree or
  1e-6 mm on a session where OpenCV returned a result (the same formulation must give
  the same numbers; where OpenCV silently returns the identity, as its Tsai does with
  fewer than two informative motions, the session is counted, not compared);
- a method's median or 90th percentile error against the truth (rotation degrees,
  translation mm), over the sessions both solved, is worse than OpenCV's same method
  by more than 1e-6;
- a method of ours fails on a session.
Prints per setup and method the median / p90 errors of both.

Usage: .venv/bin/python interop/check_handeye_opencv.py
       [--example target/release/examples/handeye_solve] [--trials 200] [--exact 20]
       [--seed 1] [--stereocal target/release/stereocal]
"""

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np
from bag_images import messages
from check_pose_opencv import run
from pose_session import rotation_of

REPO = Path(__file__).resolve().parent.parent
SETUPS = ("eye-in-hand", "eye-to-hand")
HAND_EYE = {"tsai": cv2.CALIB_HAND_EYE_TSAI, "park": cv2.CALIB_HAND_EYE_PARK,
            "horaud": cv2.CALIB_HAND_EYE_HORAUD, "andreff": cv2.CALIB_HAND_EYE_ANDREFF,
            "daniilidis": cv2.CALIB_HAND_EYE_DANIILIDIS}
ROBOT_WORLD = {"shah": cv2.CALIB_ROBOT_WORLD_HAND_EYE_SHAH,
               "li": cv2.CALIB_ROBOT_WORLD_HAND_EYE_LI}
METHODS = tuple(HAND_EYE) + tuple(ROBOT_WORLD)
TARGET_NOISE = (0.002, 0.005)
ROBOT_NOISE = (0.001, 0.001)
SAME_DEG = 1e-6
SAME_MM = 1e-6
EXACT = 1e-9


def pose(rotation, translation):
    h = np.eye(4)
    h[:3, :3] = rotation
    h[:3, 3] = translation
    return h


def random_pose(rng, degrees, metres):
    """OpenCV's test's draw: unnormalized direction, angle of random sign, translation
    components of random sign."""
    axis = rng.uniform(-1.0, 1.0, 3)
    angle = np.radians(rng.uniform(*degrees)) * rng.choice([-1.0, 1.0])
    t = rng.uniform(*metres, 3) * rng.choice([-1.0, 1.0], 3)
    return pose(cv2.Rodrigues(axis * angle)[0], t)


def noisy(rng, h, rad, metres):
    """A pose with Gaussian noise on its rotation vector's components and its
    translation's, as OpenCV's test adds it."""
    rvec = cv2.Rodrigues(h[:3, :3])[0].ravel() + rng.normal(0.0, rad, 3)
    return pose(cv2.Rodrigues(rvec)[0], h[:3, 3] + rng.normal(0.0, metres, 3))


def session(rng, setup, noise):
    """(samples as (base_from_tool, camera_from_target), mount_from_camera)."""
    if setup == "eye-in-hand":
        mount_from_camera = random_pose(rng, (10, 50), (0.05, 0.5))
        anchor_from_target = random_pose(rng, (5, 85), (0.5, 3.5))
    else:
        mount_from_camera = random_pose(rng, (10, 50), (0.5, 3.5))
        anchor_from_target = random_pose(rng, (5, 85), (0.05, 0.5))
    samples = []
    for _ in range(10):
        base_from_tool = random_pose(rng, (5, 45), (0.5, 1.5))
        anchor_from_mount = base_from_tool if setup == "eye-in-hand" else np.linalg.inv(base_from_tool)
        camera_from_target = np.linalg.inv(anchor_from_mount @ mount_from_camera) @ anchor_from_target
        if noise:
            base_from_tool = noisy(rng, base_from_tool, *ROBOT_NOISE)
            camera_from_target = noisy(rng, camera_from_target, *TARGET_NOISE)
        samples.append((base_from_tool, camera_from_target))
    return samples, mount_from_camera


def transform_json(h):
    return {"rotation": h[:3, :3].ravel().tolist(), "translation": h[:3, 3].tolist()}


def from_json(t):
    return pose(np.array(t["rotation"]).reshape(3, 3), np.array(t["translation"]))


def ours(example, setup, sessions):
    problems = [{"samples": [{"base_from_tool": transform_json(b), "camera_from_target": transform_json(c)}
                             for b, c in samples]} for samples, _ in sessions]
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump({"setup": setup, "problems": problems}, f)
        path = f.name
    out = subprocess.run([str(example), path], check=True, capture_output=True, text=True).stdout
    Path(path).unlink()
    return json.loads(out)["problems"]


def opencv(setup, samples, method):
    """OpenCV's mount_from_camera for one method, or None when it returned the identity
    it falls back to."""
    base_from_tool = [b for b, _ in samples]
    camera_from_target = [c for _, c in samples]
    if method in HAND_EYE:
        robot = base_from_tool if setup == "eye-in-hand" else [np.linalg.inv(b) for b in base_from_tool]
        r, t = cv2.calibrateHandEye([h[:3, :3] for h in robot], [h[:3, 3] for h in robot],
                                    [h[:3, :3] for h in camera_from_target],
                                    [h[:3, 3] for h in camera_from_target], method=HAND_EYE[method])
        result = pose(r, t.ravel())
    else:
        mount_from_anchor = [np.linalg.inv(b) for b in base_from_tool] if setup == "eye-in-hand" \
            else base_from_tool
        _, _, r_z, t_z = cv2.calibrateRobotWorldHandEye(
            [h[:3, :3] for h in camera_from_target], [h[:3, 3] for h in camera_from_target],
            [h[:3, :3] for h in mount_from_anchor], [h[:3, 3] for h in mount_from_anchor],
            method=ROBOT_WORLD[method])
        result = np.linalg.inv(pose(r_z, t_z.ravel()))
    if np.allclose(result, np.eye(4), atol=0.0):
        return None
    return result


def errors(found, truth):
    """(rotation degrees, translation mm) between two poses."""
    r = found[:3, :3] @ truth[:3, :3].T
    skew = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    angle = np.degrees(np.arctan2(np.linalg.norm(skew) / 2, (np.trace(r) - 1) / 2))
    return float(angle), float(np.linalg.norm(found[:3, 3] - truth[:3, 3]) * 1000)


def poses(bag, topic):
    """{stamp nanoseconds: 4x4 pose} of a PoseStamped topic, read with rosbags."""
    out = {}
    for _, msg in messages(bag, [topic]):
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        p = msg.pose.position
        out[stamp] = pose(rotation_of(msg.pose.orientation), [p.x, p.y, p.z])
    return out


def check_command(stereocal, failures):
    """`stereocal handeye` on rendered sessions against OpenCV on the same poses."""
    print("\nstereocal handeye on rendered sessions against OpenCV on the bag's poses, read by rosbags")
    for scene, setup in (("handeye-in-hand", "eye-in-hand"), ("handeye-to-hand", "eye-to-hand")):
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            run([stereocal, "synth", "--scene", scene, "--out", tmp / "synth", "--frames", "15"])
            run([stereocal, "pose", "--bag", tmp / "synth" / "bag", "--out", tmp / "posed",
                 "--size", "9x6", "--square", "0.03"])
            report = json.loads(run([stereocal, "handeye", "--bag", tmp / "posed", "--setup", setup,
                                     "--target-pose-topic", "/camera/target_pose",
                                     "--robot-pose-topic", "/robot/tool_pose",
                                     "--out", tmp / "handeye", "--json"]))
            targets = poses(tmp / "posed", "/camera/target_pose")
            robot = poses(tmp / "posed", "/robot/tool_pose")
            left_out = {round(r["stamp"] * 1e9) for r in report["samples_rejected"]}
            samples = [(robot[stamp], target) for stamp, target in sorted(targets.items())
                       if stamp in robot and all(abs(stamp - s) > 1000 for s in left_out)]
            if len(samples) != report["samples"]:
                failures.append(f"{setup}: {len(samples)} samples paired by rosbags, "
                                f"{report['samples']} used by stereocal handeye")
                continue
            worst = (0.0, 0.0)
            for method in METHODS:
                if method not in report["results"]:
                    failures.append(f"{setup}: stereocal handeye has no {method} result")
                    continue
                ours_pose = from_json(report["results"][method])
                reference = opencv(setup, samples, method)
                if reference is None:
                    failures.append(f"{setup}: OpenCV {method} returned no result")
                    continue
                difference = errors(ours_pose, reference)
                worst = (max(worst[0], difference[0]), max(worst[1], difference[1]))
                if difference[0] > SAME_DEG or difference[1] > SAME_MM:
                    failures.append(f"{setup} {method}: stereocal handeye differs from OpenCV by "
                                    f"{difference[0]:.3g} deg, {difference[1]:.3g} mm")
            print(f"  {setup}: {len(samples)} samples, {len(report['samples_rejected'])} left out, "
                  f"chosen {report['chosen']}; largest difference from OpenCV over the seven "
                  f"methods {worst[0]:.1e} deg, {worst[1]:.1e} mm")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--example", type=Path,
                        default=REPO / "target" / "release" / "examples" / "handeye_solve")
    parser.add_argument("--trials", type=int, default=200)
    parser.add_argument("--exact", type=int, default=20)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--stereocal", type=Path,
                        help="also check the `stereocal handeye` command on rendered bags")
    args = parser.parse_args()
    if not args.example.exists():
        sys.exit(f"{args.example} not found: cargo build --release -p stereocal-vision --example handeye_solve")
    rng = np.random.default_rng(args.seed)
    failures = []
    print(f"OpenCV {cv2.__version__}; {args.trials} noisy and {args.exact} exact sessions of 10 poses per setup")
    for setup in SETUPS:
        exact = [session(rng, setup, noise=False) for _ in range(args.exact)]
        for (samples, truth), results in zip(exact, ours(args.example, setup, exact)):
            for method in METHODS:
                result = results[method]
                if "error" in result:
                    failures.append(f"{setup} exact {method}: {result['error']}")
                    continue
                r, t = errors(from_json(result["mount_from_camera"]), truth)
                if np.radians(r) > EXACT or t / 1000 > EXACT:
                    failures.append(f"{setup} exact {method}: {r:.3g} deg, {t:.3g} mm from the truth")
        sessions = [session(rng, setup, noise=True) for _ in range(args.trials)]
        solved = ours(args.example, setup, sessions)
        print(f"\n{setup}: error against the truth, median / p90 (rotation deg, translation mm)")
        print(f"{'method':11} {'stereocal':>30} {'OpenCV':>30}   largest difference from OpenCV")
        for method in METHODS:
            mine, theirs, differences, opencv_failed = [], [], [], 0
            for (samples, truth), results in zip(sessions, solved):
                result = results[method]
                if "error" in result:
                    failures.append(f"{setup} {method}: {result['error']}")
                    continue
                found = from_json(result["mount_from_camera"])
                reference = opencv(setup, samples, method)
                if reference is None:
                    opencv_failed += 1
                    continue
                mine.append(errors(found, truth))
                theirs.append(errors(reference, truth))
                differences.append(errors(found, reference))
            if not mine or not theirs:
                failures.append(f"{setup} {method}: nothing to compare")
                continue
            stats = {}
            for name, values in (("ours", np.array(mine)), ("opencv", np.array(theirs))):
                stats[name] = np.concatenate([np.median(values, axis=0), np.percentile(values, 90, axis=0)])
            worst = np.max(np.array(differences), axis=0)
            text = lambda s: f"{s[0]:.4f}/{s[2]:.4f} deg {s[1]:.2f}/{s[3]:.2f} mm"
            note = f"; OpenCV returned no result on {opencv_failed}" if opencv_failed else ""
            print(f"{method:11} {text(stats['ours']):>30} {text(stats['opencv']):>30}   "
                  f"{worst[0]:.1e} deg, {worst[1]:.1e} mm{note}")
            if worst[0] > SAME_DEG or worst[1] > SAME_MM:
                failures.append(f"{setup} {method}: differs from OpenCV's by {worst[0]:.3g} deg, {worst[1]:.3g} mm")
            margin = np.array([SAME_DEG, SAME_MM, SAME_DEG, SAME_MM])
            if np.any(stats["ours"] > stats["opencv"] + margin):
                failures.append(f"{setup} {method}: errors {stats['ours']} worse than OpenCV's {stats['opencv']}")
    if args.stereocal:
        check_command(args.stereocal, failures)
    if failures:
        print("\nFAILED:\n  " + "\n  ".join(failures[:20]))
        sys.exit(1)
    print("\nevery method recovers exact transforms, gives OpenCV's numbers on noisy sessions, "
          "and is no less accurate")


if __name__ == "__main__":
    main()
