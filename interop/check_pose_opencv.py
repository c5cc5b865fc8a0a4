"""`stereocal pose` against the ground truth, beside cv2.solvePnP on the same corners.

For each lens model (plumb_bob, rational_polynomial, equidistant), target (the
hand-eye scenes' default 9x6 chessboard of 30 mm squares; the ChArUco board
config/boards/charuco_10x7_40mm.yaml) and condition (clean: `--bad-frames 0`; bad:
`--bad-frames 0.5`, blurred, motion-blurred or partly out of view),
`stereocal synth --scene handeye-in-hand` renders a seeded session with its ground
truth, and:
- `stereocal pose --json` estimates the target's pose in every frame;
- the images, exported from the bag with rosbags as PNG, go through the
  `detect_target` example: the detector the pose stage uses, so the same corners
  (checked: our pose reprojects onto them with the RMS `stereocal pose` reports);
- OpenCV solves each frame's corners with cv2.solvePnP, SOLVEPNP_ITERATIVE and
  SOLVEPNP_SQPNP, given the true K and D (equidistant: the corners undistorted by
  cv2.fisheye.undistortPoints, solved with identity K and no distortion).
Rotation (degrees) and translation (mm) errors against the truth are compared over the
frames where all three have a pose; frames where one side has a pose and the other
none are counted, with our reasons.

Exits non-zero when:
- in a row of a pinhole model, our median or 95th percentile rotation or translation
  error is worse than ITERATIVE's by more than 1e-6 (relative, and degrees or mm):
  there ITERATIVE minimizes the same pixel reprojection error on the same corners, so
  ours must be the same minimum (to its convergence) or a lower one;
- over all rows, SQPNP's pose (or, with the fisheye model, ITERATIVE's on the
  undistorted corners) is the closer to the truth on significantly more frames than
  ours (a one-sided sign test on the paired errors, p < 0.01, for rotation and for
  translation): those minimize another error (on the z = 1 plane), so frame by frame
  either can be the closer by chance, and a row's median of a dozen frames says
  nothing; the minimum of the pixel error should not lose over many;
- on a frame our pose's RMS reprojection error on the corners is above either OpenCV
  pose's by more than 1e-9 px;
- our corners and `stereocal pose`'s differ, a row has no frame to compare, or a
  command fails.
A second table shows, per row, the reprojection comparison and on how many frames our
rotation is the closer to the truth.

Usage: .venv/bin/python interop/check_pose_opencv.py [--frames N] [--seed S]
       [--bad-frames F] [--bin path/to/stereocal] [--detect path/to/detect_target]
"""

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from collections import Counter
from math import comb
from pathlib import Path

import cv2
import numpy as np
from bag_images import grey_images, messages
from check_charuco_opencv import read_board

REPO = Path(__file__).resolve().parent.parent
IMAGE_TOPIC = "/camera/image_raw"
INFO_TOPIC = "/camera/camera_info"
MODELS = ("plumb_bob", "rational_polynomial", "equidistant")
CHARUCO = REPO / "config/boards/charuco_10x7_40mm.yaml"
TARGETS = (("chessboard", None), ("charuco", CHARUCO))
METHODS = ("stereocal", "ITERATIVE", "SQPNP")
CV_FLAGS = {"ITERATIVE": cv2.SOLVEPNP_ITERATIVE, "SQPNP": cv2.SOLVEPNP_SQPNP}
# Margins by which our statistics may exceed ITERATIVE's on the same minimum: both stop
# iterating within about 1e-8 degree and 1e-8 mm of it.
RELATIVE_TOLERANCE = 1e-6
SAME_MINIMUM = 1e-6
# Largest difference between the RMS `stereocal pose` reports and our pose's RMS on the
# example's corners: the same corners give the same number to rounding.
SAME_CORNERS_PX = 1e-6
# Largest excess of our pose's RMS reprojection error over OpenCV's on the same corners:
# ours is the minimum of that error, so only rounding.
RMS_TOLERANCE_PX = 1e-9


def built(path):
    release = REPO / "target" / "release" / path
    return release if release.exists() else REPO / "target" / "debug" / path


def run(command):
    """stdout of `command`; exits with its stderr when it fails."""
    done = subprocess.run([str(c) for c in command], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(map(str, command))} failed ({done.returncode}):\n{done.stderr}")
    return done.stdout


def nanoseconds(sec, nanosec):
    return sec * 1_000_000_000 + nanosec


def pose_matrix(rotation, translation):
    return np.asarray(rotation, dtype=float).reshape(3, 3), np.asarray(translation, dtype=float)


def rotation_angle_degrees(r):
    """The angle of a rotation matrix, degrees; accurate near zero, where cv2.Rodrigues
    returns a zero vector for angles below about 1e-5 rad."""
    skew = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return float(np.degrees(np.arctan2(np.linalg.norm(skew) / 2, (np.trace(r) - 1) / 2)))


def pose_errors(pose, truth):
    """Rotation error in degrees and translation error in mm of `pose` against `truth`."""
    (r, t), (r_true, t_true) = pose, truth
    return rotation_angle_degrees(r @ r_true.T), float(np.linalg.norm(t - t_true) * 1e3)


def grid_points(cols, square):
    """Target points of corner ids: row-major inner corners from the first one, as
    stereocal's `Target::object_points` (and the truth's target frame)."""
    def points(ids):
        ids = np.asarray(ids)
        return np.stack([ids % cols * square, ids // cols * square, np.zeros(len(ids))], 1)
    return points


def project(points, pose, k, d, fisheye):
    rvec, _ = cv2.Rodrigues(pose[0])
    tvec = pose[1].reshape(3, 1)
    if fisheye:
        pixels, _ = cv2.fisheye.projectPoints(points.reshape(-1, 1, 3), rvec, tvec, k, d)
    else:
        pixels, _ = cv2.projectPoints(points, rvec, tvec, k, d)
    return pixels.reshape(-1, 2)


def opencv_pose(points, pixels, k, d, fisheye, method):
    """cv2.solvePnP's pose `(R, t)` of camera_from_target, or None when it returns none."""
    if fisheye:
        normalized = cv2.fisheye.undistortPoints(pixels.reshape(-1, 1, 2), k, d)
        pixels, k, d = normalized.reshape(-1, 2), np.eye(3), None
    try:
        ok, rvec, tvec = cv2.solvePnP(points, pixels, k, d, flags=CV_FLAGS[method])
    except cv2.error:
        return None
    if not ok or not (np.all(np.isfinite(rvec)) and np.all(np.isfinite(tvec))):
        return None
    return cv2.Rodrigues(rvec)[0], tvec.ravel()


def detect(binary, board_file, paths):
    """{path: (ids, corners)} of the example's detections; absent where none."""
    found = {}
    for line in run([binary, board_file, *paths]).splitlines():
        record = json.loads(line)
        if record["ids"] is not None:
            found[record["image"]] = (np.array(record["ids"]), np.array(record["corners"], dtype=float))
    return found


def session(args, tmp, model, target, board_file, bad):
    """One session: per frame, the truth and each method's pose (or our reason for
    none), and the failures found on the way."""
    out = tmp / f"{model}_{target}_{bad}"
    synth = [args.bin, "synth", "--scene", "handeye-in-hand", "--out", out, "--frames", args.frames,
             "--seed", args.seed, "--model", model, "--bad-frames", bad]
    run(synth + (["--board", board_file] if board_file else []))
    truth = json.loads((out / "ground_truth.json").read_text())
    board = truth["board"]
    cols, rows, square = board["inner_corners_cols"], board["inner_corners_rows"], board["square_size_m"]
    if board_file is None:
        board_file = out / "chessboard.yaml"
        board_file.write_text(f"pattern: chessboard\ncols: {cols}\nrows: {rows}\nsquare_size: {square}\n")
        pattern = ["--size", f"{cols}x{rows}", "--square", square]
    else:
        spec = read_board(board_file)
        pattern = ["--pattern", "charuco", "--size", f"{spec['squares_x']}x{spec['squares_y']}",
                   "--square", spec["square_size"], "--charuco_marker_size", spec["marker_size"],
                   "--aruco_dict", spec["dictionary"]]
    ours = json.loads(run([args.bin, "pose", "--bag", out / "bag", "--out", out / "poses",
                           "--topic", IMAGE_TOPIC, *pattern, "--json"]))
    ours = {round(f["stamp"] * 1e6): f for f in ours["frames"]}

    info = next(m for _, m in messages(out / "bag", [INFO_TOPIC]))
    camera = truth["cameras"][0]
    k = np.array(camera["camera_matrix_row_major"], dtype=float).reshape(3, 3)
    d = np.array(camera["distortion_coefficients"], dtype=float)
    failures = []
    if not (np.array_equal(np.asarray(info.k), k.ravel()) and np.array_equal(np.asarray(info.d), d)):
        failures.append(f"{out.name}: the bag's camera_info is not the true camera")
    fisheye = camera["distortion_model"] == "equidistant"

    paths = {}
    for _, stamp, img in grey_images(out / "bag", [IMAGE_TOPIC]):
        paths[nanoseconds(*stamp)] = out / f"{stamp[0]}_{stamp[1]:09d}.png"
        cv2.imwrite(str(paths[nanoseconds(*stamp)]), img)
    corners = detect(args.detect, board_file, list(paths.values()))
    points_of = grid_points(cols, square)

    frames = []
    for frame in truth["frames"]:
        stamp = nanoseconds(frame["stamp"]["sec"], frame["stamp"]["nanosec"])
        where = f"{model} {target} bad-frames {bad}, frame {frame['index']} ({frame['kind']})"
        view = frame["views"][0]
        true_pose = pose_matrix(view["camera_from_target"]["rotation_row_major"],
                                view["camera_from_target"]["translation_m"])
        # The truth's target frame must be the one the points below are in.
        visible = [c for c in view["corners"] if c["visible"]]
        if visible:
            ids = [c["id"] for c in visible]
            drift = np.abs(project(points_of(ids), true_pose, k, d, fisheye)
                           - np.array([c["pixel"] for c in visible])).max()
            if drift > 1e-3:
                failures.append(f"{where}: the true pose puts the corners {drift:.3g} px from the "
                                "truth's pixels: target frames differ")
        record = ours.get(round(stamp / 1e3))
        if record is None:
            failures.append(f"{where}: `stereocal pose` printed no record")
            continue
        entry = {"where": where, "kind": frame["kind"], "poses": {}, "errors": {}}
        if "rejected" in record:
            entry["reason"] = record["rejected"]
        else:
            entry["poses"]["stereocal"] = pose_matrix(record["camera_from_target"]["rotation"],
                                                      record["camera_from_target"]["translation"])
        found = corners.get(str(paths[stamp]))
        if found is None:
            if "rejected" not in record:
                failures.append(f"{where}: `stereocal pose` has a pose but detect_target no corners")
            entry["no_corners"] = True
            frames.append(entry)
            continue
        ids, pixels = found
        points = points_of(ids)
        for method in CV_FLAGS:
            pose = opencv_pose(points, pixels, k, d, fisheye, method)
            if pose is not None:
                entry["poses"][method] = pose
        entry["errors"] = {m: pose_errors(p, true_pose) for m, p in entry["poses"].items()}
        # Each pose's RMS pixel reprojection error on these corners through the true
        # model: the objective our pose minimizes.
        entry["rms"] = {m: float(np.sqrt(np.mean(np.sum(
            (project(points, p, k, d, fisheye) - pixels) ** 2, 1)))) for m, p in entry["poses"].items()}
        if "stereocal" in entry["rms"] and abs(entry["rms"]["stereocal"] - record["rms"]) > SAME_CORNERS_PX:
            failures.append(f"{where}: our pose reprojects onto the example's corners with "
                            f"{entry['rms']['stereocal']:.9f} px RMS, `stereocal pose` reports "
                            f"{record['rms']:.9f} px: not the same corners")
        frames.append(entry)
    return frames, failures


def sign_test(wins, trials):
    """P(at least `wins` successes in `trials` fair coin tosses)."""
    return sum(comb(trials, k) for k in range(wins, trials + 1)) / 2 ** trials if trials else 1.0


def reason_kind(reason):
    """The kind of a refusal: `pose refused: reprojection error 2.7 px ...` gives
    `reprojection error`."""
    detail = reason.split(": ", 1)[-1]
    return re.split(r"[:\d(]", detail, maxsplit=1)[0].strip()


def percentile_row(values):
    return float(np.median(values)), float(np.percentile(values, 95))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--bad-frames", type=float, default=0.5,
                        help="fraction of bad frames in the 'bad' condition")
    parser.add_argument("--bin", type=Path, default=built("stereocal"))
    parser.add_argument("--detect", type=Path, default=built("examples/detect_target"))
    args = parser.parse_args()
    for tool, build in ((args.bin, "cargo build --release --bin stereocal"),
                        (args.detect, "cargo build --release -p stereocal-vision --example detect_target")):
        if not tool.exists():
            sys.exit(f"{tool} is missing: {build}")

    started = time.perf_counter()
    failures, rows, notes = [], [], []
    paired = {"SQPNP": [], "ITERATIVE (fisheye corners undistorted)": []}
    conditions = (("clean", 0.0), ("bad", args.bad_frames))
    with tempfile.TemporaryDirectory() as tmp:
        for model in MODELS:
            for target, board_file in TARGETS:
                for condition, bad in conditions:
                    frames, found = session(args, Path(tmp), model, target, board_file, bad)
                    failures += found
                    label = f"{model:19} {target:10} {condition:5}"
                    both = [f for f in frames if all(m in f["poses"] for m in METHODS)]
                    refused = [f for f in frames if "stereocal" not in f["poses"]
                               and any(m in f["poses"] for m in CV_FLAGS)]
                    cv_none = [f for f in frames if "stereocal" in f["poses"]
                               and not all(m in f["poses"] for m in CV_FLAGS)]
                    no_corners = sum(1 for f in frames if f.get("no_corners"))
                    for f in refused:
                        cv = ", ".join(f"{m} {f['errors'][m][0]:.3f} deg {f['errors'][m][1]:.2f} mm"
                                       for m in CV_FLAGS if m in f["errors"])
                        notes.append(f"{f['where']}: OpenCV has a pose ({cv}), we refused: {f['reason']}")
                    for f in cv_none:
                        missing = [m for m in CV_FLAGS if m not in f["poses"]]
                        notes.append(f"{f['where']}: OpenCV {'/'.join(missing)} returned no pose, "
                                     f"ours is {f['errors']['stereocal'][0]:.3f} deg off")
                    if not both:
                        failures.append(f"{' '.join(label.split())}: no frame where all three have a pose")
                        rows.append((label, len(frames), 0, len(refused), len(cv_none), no_corners, None))
                        continue
                    stats = {}
                    for method in METHODS:
                        rot = [f["errors"][method][0] for f in both]
                        trans = [f["errors"][method][1] for f in both]
                        stats[method] = (*percentile_row(rot), *percentile_row(trans))
                    names = ("median rotation", "p95 rotation", "median translation", "p95 translation")
                    # With a pinhole model ITERATIVE minimizes our objective; with the
                    # fisheye model it solves the undistorted corners, another error.
                    if model == "equidistant":
                        paired["ITERATIVE (fisheye corners undistorted)"] += [
                            (f["errors"]["stereocal"], f["errors"]["ITERATIVE"]) for f in both]
                    else:
                        for i, name in enumerate(names):
                            same_objective = stats["ITERATIVE"][i]
                            if stats["stereocal"][i] > same_objective * (1 + RELATIVE_TOLERANCE) + SAME_MINIMUM:
                                failures.append(
                                    f"{' '.join(label.split())}: our {name} error {stats['stereocal'][i]:.6g} "
                                    f"is above ITERATIVE's {same_objective:.6g}")
                    paired["SQPNP"] += [(f["errors"]["stereocal"], f["errors"]["SQPNP"]) for f in both]
                    # The objective: our pose should explain the corners at least as well.
                    excess = [f["rms"]["stereocal"] - min(f["rms"][m] for m in CV_FLAGS) for f in both]
                    for f, e in zip(both, excess):
                        if e > RMS_TOLERANCE_PX:
                            failures.append(f"{f['where']}: our pose's reprojection RMS is {e:.3g} px above "
                                            "OpenCV's on the same corners")
                    closer = {m: sum(f["errors"]["stereocal"][0] <= f["errors"][m][0] for f in both)
                              for m in CV_FLAGS}
                    stats["objective"] = (sum(e <= RMS_TOLERANCE_PX for e in excess), max(excess), closer)
                    rows.append((label, len(frames), len(both), len(refused), len(cv_none), no_corners, stats))

    print(f"OpenCV {cv2.__version__}; {args.frames} frames per session, seed {args.seed}; "
          f"errors against the truth over the frames all three posed: median / p95")
    header = (f"{'model':19} {'target':10} {'cond':5} {'n':>2} {'cmp':>3} {'ref':>3} {'cvx':>3} {'nc':>2} | "
              + " | ".join(f"{m:^27}" for m in METHODS))
    print(header)
    print(f"{'':50}| " + " | ".join(f"{'rot deg':^13} {'trans mm':^13}" for _ in METHODS))
    for label, n, compared, refused, cv_none, no_corners, stats in rows:
        line = f"{label} {n:2} {compared:3} {refused:3} {cv_none:3} {no_corners:2} | "
        if stats is None:
            print(line + "no frame to compare")
            continue
        print(line + " | ".join(
            f"{s[0]:6.4f}/{s[1]:6.4f} {s[2]:6.3f}/{s[3]:6.3f}" for s in (stats[m] for m in METHODS)))
    print("n: frames, cmp: compared (all three posed), ref: we refused and OpenCV posed, "
          "cvx: we posed and OpenCV did not, nc: no corners found")
    print("\nthe same frames: our RMS pixel reprojection error against OpenCV's least, and whose "
          "rotation is closer to the truth")
    print(f"{'model':19} {'target':10} {'cond':5} | ours least | max(ours - OpenCV) px | "
          "ours closer than ITERATIVE | than SQPNP")
    for label, _, compared, *_, stats in rows:
        if stats is not None:
            least, worst, closer = stats["objective"]
            print(f"{label} | {least:4}/{compared:<4} | {worst:+20.3e} | {closer['ITERATIVE']:11}/{compared:<13}"
                  f" | {closer['SQPNP']:4}/{compared}")
    reasons = Counter(reason_kind(note.split("we refused: ", 1)[1]) for note in notes if "we refused" in note)
    for note in notes:
        print(note)
    if reasons:
        print("our refusals where OpenCV returned a pose: "
              + ", ".join(f"{count} x {reason}" for reason, count in reasons.most_common()))
    for method, pairs in paired.items():
        for axis, name in ((0, "rotation"), (1, "translation")):
            ours_closer = sum(o[axis] < q[axis] for o, q in pairs)
            theirs_closer = sum(o[axis] > q[axis] for o, q in pairs)
            p_value = sign_test(theirs_closer, ours_closer + theirs_closer)
            print(f"{name}: ours closer to the truth than {method} on {ours_closer} frames, it on "
                  f"{theirs_closer} (one-sided sign test p = {p_value:.3g})")
            if p_value < 0.01:
                failures.append(f"{method} is closer to the truth in {name} on significantly more "
                                f"frames ({theirs_closer} against {ours_closer}, p = {p_value:.3g})")
    print(f"wall time {time.perf_counter() - started:.1f} s")
    for failure in failures:
        print("MISMATCH:", failure)
    if failures:
        sys.exit(1)
    print("stereocal pose is ITERATIVE's minimum or a lower one on every frame, and no farther "
          "from the truth than SQPNP over all frames")


if __name__ == "__main__":
    main()
