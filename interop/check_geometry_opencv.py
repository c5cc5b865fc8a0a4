#!/usr/bin/env python3
"""Two-view geometry, stereocal's `vision::geometry` against OpenCV, side by side on the
same correspondences.

The problems (seeded, --seed): a distortion-free 1024x768 camera (fx 800, fy 805, cx 515,
cy 380) seeing, from two poses (turned up to ~12 degrees, moved 0.3 to 0.6 m), either a
plane 3 to 6 m away ("homography" problems) or a general scene 3 to 10 m deep ("scene"
problems); --points correspondences each, Gaussian noise of --noise px on every
coordinate, and a fraction --outliers of them replaced, in the second image, by pixels
drawn uniformly over the image. Ours run through the `geometry_solve` example; OpenCV
with cv2.setNumThreads(1):
- findHomography with RANSAC (3 px, 0.995, 2000 iterations) and LMEDS, against our
  find_homography with the same options;
- findFundamentalMat with FM_RANSAC (1 px, 0.99, 1000 iterations) against our
  find_fundamental, and FM_8POINT on the true inliers against our fundamental_8point;
- findEssentialMat with RANSAC (1 px, 0.999, 1000 iterations) and recoverPose on its
  mask, against our find_essential and recover_pose;
- triangulatePoints and correctMatches with the true projections and fundamental
  matrix, on the true inliers, against our triangulate_linear and correct_matches.

Asserted (exit status 1 on any failure, each named):
- agreement: homographies transfer the noise-free points to within 0.5 px RMS of each
  other; both fundamental matrices explain the noise-free correspondences to 1 px RMS
  Sampson distance (OpenCV's is the best 7-point sample's, not refitted on its inliers:
  about 0.5 px here, ours about 0.15); FM_8POINT and ours agree to 1e-6 relative; the
  poses recovered from E agree to 1 degree in rotation and 6 degrees in the direction
  of translation (OpenCV's E is also a minimal sample's, not refined: over seeds 1 to 8
  it is up to 0.6 and 4.5 degrees off the truth), and ours is within 0.3 and 2 degrees
  of the truth; triangulated points agree to 1e-6 relative; corrected matches to
  1e-6 px;
- accuracy: our error over the true inliers (transfer error for H, Sampson distance for
  F and E) is no higher than OpenCV's, with 1 % slack for ties;
- inliers: our masks misclassify (true inliers rejected plus outliers accepted) no more
  correspondences than OpenCV's, with a slack of 1 per problem for ties at the threshold.
Note that OpenCV's F threshold bounds the larger distance of a point to its epipolar
line, ours the Sampson distance (about that distance over sqrt(2) for noise in one
image): the same number is given to both.

Printed: per solver the figures above, our RANSAC iteration counts next to the count
OpenCV's stopping rule gives at the inlier ratio of the mask it returns (OpenCV does not
report its own), and the time per call, median over problems, with the ratio OpenCV
time / our time (above 1, ours is faster).

Usage: .venv/bin/python interop/check_geometry_opencv.py
       [--example target/release/examples/geometry_solve] [--problems 4] [--points 200]
       [--noise 0.5] [--outliers 0.25] [--calls 20] [--repeats 5] [--seed 1]
"""

import argparse
import json
import math
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
FOCAL = (K[0, 0] + K[1, 1]) / 2
H_RANSAC = {"threshold": 3.0, "confidence": 0.995, "max_iterations": 2000}
H_LMEDS = {"confidence": 0.995, "max_iterations": 2000}
F_RANSAC = {"threshold": 1.0, "confidence": 0.99, "max_iterations": 1000}
E_RANSAC = {"threshold": 1.0, "confidence": 0.999, "max_iterations": 1000}
SLACK = 1.01


def random_pose(rng):
    axis = rng.normal(size=3)
    rvec = axis / np.linalg.norm(axis) * rng.uniform(0.05, 0.2)
    direction = np.array([rng.uniform(-1, 1), rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3)])
    t = direction / np.linalg.norm(direction) * rng.uniform(0.3, 0.6)
    return cv2.Rodrigues(rvec)[0], t


def project(points, rotation=np.eye(3), t=np.zeros(3)):
    cam = points @ rotation.T + t
    pix = cam @ K.T
    return pix[:, :2] / pix[:, 2:], cam[:, 2]


def inside(p):
    return (p[:, 0] >= 0) & (p[:, 0] <= WIDTH - 1) & (p[:, 1] >= 0) & (p[:, 1] <= HEIGHT - 1)


def correspondences(rng, points, rotation, t, count, noise, outliers):
    a, za = project(points)
    b, zb = project(points, rotation, t)
    keep = inside(a) & inside(b) & (za > 0) & (zb > 0)
    a, b = a[keep][:count], b[keep][:count]
    if len(a) < count:
        raise RuntimeError("too few visible points")
    outlier = rng.uniform(size=count) < outliers
    noisy_a = a + rng.normal(0, noise, a.shape)
    noisy_b = b + rng.normal(0, noise, b.shape)
    noisy_b[outlier] = np.column_stack([rng.uniform(0, WIDTH - 1, outlier.sum()),
                                        rng.uniform(0, HEIGHT - 1, outlier.sum())])
    return noisy_a, noisy_b, a, b, ~outlier


def make_problems(args):
    rng = np.random.default_rng(args.seed)
    problems = []
    for index in range(args.problems):
        rotation, t = random_pose(rng)
        normal = np.array([rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 1.0])
        normal /= np.linalg.norm(normal)
        distance = rng.uniform(3.0, 6.0)
        rays = np.column_stack([rng.uniform(-0.7, 0.7, 4 * args.points),
                                rng.uniform(-0.5, 0.5, 4 * args.points), np.ones(4 * args.points)])
        plane = rays * (distance / (rays @ normal))[:, None]
        a, b, clean_a, clean_b, inlier = correspondences(rng, plane, rotation, t, args.points,
                                                         args.noise, args.outliers)
        problems.append({"name": f"plane_{index}", "kind": "homography", "points_a": a.tolist(),
                         "points_b": b.tolist(), "ransac": H_RANSAC, "lmeds": H_LMEDS,
                         "truth": {"clean_a": clean_a, "clean_b": clean_b, "inlier": inlier}})
    for index in range(args.problems):
        rotation, t = random_pose(rng)
        z = rng.uniform(3.0, 10.0, 4 * args.points)
        scene = np.column_stack([rng.uniform(-0.7, 0.7, z.size) * z, rng.uniform(-0.5, 0.5, z.size) * z, z])
        a, b, clean_a, clean_b, inlier = correspondences(rng, scene, rotation, t, args.points,
                                                         args.noise, args.outliers)
        truth = {"clean_a": clean_a, "clean_b": clean_b, "inlier": inlier, "rotation": rotation, "t": t}
        problems.append({"name": f"scene_{index}", "kind": "scene", "points_a": a.tolist(),
                         "points_b": b.tolist(), "fundamental": F_RANSAC, "essential": E_RANSAC,
                         "max_distance": 50.0, "truth": truth})
        problems.append({"name": f"eight_point_{index}", "kind": "eight_point",
                         "points_a": a[inlier].tolist(), "points_b": b[inlier].tolist(), "truth": {}})
        pa = K @ np.hstack([np.eye(3), np.zeros((3, 1))])
        pb = K @ np.hstack([rotation, t[:, None]])
        tx = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
        f = np.linalg.inv(K).T @ tx @ rotation @ np.linalg.inv(K)
        problems.append({"name": f"triangulate_{index}", "kind": "triangulate",
                         "points_a": a[inlier].tolist(), "points_b": b[inlier].tolist(),
                         "projection_a": pa.ravel().tolist(), "projection_b": pb.ravel().tolist(),
                         "fundamental_matrix": (f / f[2, 2]).ravel().tolist(), "truth": {}})
    return problems


def timed(calls, repeats, f):
    result = f()
    batches = []
    for batch in range(repeats + 1):
        start = time.perf_counter()
        for _ in range(calls):
            result = f()
        if batch:
            batches.append((time.perf_counter() - start) / calls)
    return statistics.median(batches), result


def opencv(problem, calls, repeats):
    a = np.array(problem["points_a"])
    b = np.array(problem["points_b"])
    kind = problem["kind"]
    out = {}
    if kind == "homography":
        o = H_RANSAC
        out["ransac"] = timed(calls, repeats, lambda: cv2.findHomography(
            a, b, cv2.RANSAC, o["threshold"], maxIters=o["max_iterations"], confidence=o["confidence"]))
        o = H_LMEDS
        out["lmeds"] = timed(calls, repeats, lambda: cv2.findHomography(
            a, b, cv2.LMEDS, maxIters=o["max_iterations"], confidence=o["confidence"]))
    elif kind == "scene":
        o = F_RANSAC
        out["fundamental"] = timed(calls, repeats, lambda: cv2.findFundamentalMat(
            a, b, cv2.FM_RANSAC, o["threshold"], o["confidence"], o["max_iterations"]))
        o = E_RANSAC
        out["essential"] = timed(calls, repeats, lambda: cv2.findEssentialMat(
            a, b, K, cv2.RANSAC, o["confidence"], o["threshold"], o["max_iterations"]))
        e, mask = out["essential"][1]
        out["recover_pose"] = timed(calls, repeats, lambda: cv2.recoverPose(e[:3], a, b, K, mask=mask.copy()))
    elif kind == "eight_point":
        out["eight_point"] = timed(calls, repeats, lambda: cv2.findFundamentalMat(a, b, cv2.FM_8POINT))
    elif kind == "triangulate":
        pa = np.array(problem["projection_a"]).reshape(3, 4)
        pb = np.array(problem["projection_b"]).reshape(3, 4)
        f = np.array(problem["fundamental_matrix"]).reshape(3, 3)
        out["triangulate"] = timed(calls, repeats, lambda: cv2.triangulatePoints(pa, pb, a.T, b.T))
        out["correct_matches"] = timed(calls, repeats, lambda: cv2.correctMatches(
            f, a.reshape(1, -1, 2), b.reshape(1, -1, 2)))
    return out


def transfer(h, a):
    p = np.column_stack([a, np.ones(len(a))]) @ np.asarray(h).reshape(3, 3).T
    return p[:, :2] / p[:, 2:]


def sampson(f, a, b):
    f = np.asarray(f).reshape(3, 3)
    ha = np.column_stack([a, np.ones(len(a))])
    hb = np.column_stack([b, np.ones(len(b))])
    fa = ha @ f.T
    ftb = hb @ f
    r = np.sum(hb * fa, axis=1)
    return np.abs(r) / np.sqrt(fa[:, 0] ** 2 + fa[:, 1] ** 2 + ftb[:, 0] ** 2 + ftb[:, 1] ** 2)


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def normalized_points(p):
    return (np.asarray(p) - K[:2, 2]) / np.array([K[0, 0], K[1, 1]])


def rotation_angle_degrees(r):
    skew = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return float(np.degrees(np.arctan2(np.linalg.norm(skew) / 2, (np.trace(r) - 1) / 2)))


def angle_degrees(u, v):
    u, v = np.ravel(u), np.ravel(v)
    return float(np.degrees(np.arctan2(np.linalg.norm(np.cross(u, v)), np.dot(u, v))))


def misclassified(mask, truth):
    mask = np.asarray(mask).ravel().astype(bool)
    return int(np.sum(truth & ~mask) + np.sum(~truth & mask))


def stopping_count(confidence, inliers, total, sample, cap):
    """OpenCV's RANSACUpdateNumIters at an inlier ratio."""
    denominator = 1 - (inliers / total) ** sample
    if denominator <= 0:
        return 0
    num, den = math.log(max(1 - confidence, sys.float_info.min)), math.log(denominator)
    if den >= 0 or -num >= cap * -den:
        return cap
    return round(num / den)


class Report:
    def __init__(self):
        self.failures = []
        self.rows = {}

    def check(self, ok, message):
        if not ok:
            self.failures.append(message)

    def add(self, solver, **figures):
        self.rows.setdefault(solver, []).append(figures)


def compare(problem, ours, theirs, report):
    name = problem["name"]
    truth = problem["truth"]
    a = np.array(problem["points_a"])
    b = np.array(problem["points_b"])
    kind = problem["kind"]
    if kind == "homography":
        inlier = truth["inlier"]
        for method, (sample_conf, cap) in (("ransac", (0.995, 2000)), ("lmeds", (0.995, 2000))):
            our = ours[method]
            seconds, (h, mask) = theirs[method]
            if h is None:
                report.check(False, f"{name} {method}: OpenCV found no homography")
                continue
            agreement = rms(np.linalg.norm(transfer(our["matrix"], truth["clean_a"]) -
                                           transfer(h, truth["clean_a"]), axis=1))
            our_error = rms(np.linalg.norm(transfer(our["matrix"], a[inlier]) - b[inlier], axis=1))
            cv_error = rms(np.linalg.norm(transfer(h, a[inlier]) - b[inlier], axis=1))
            our_wrong = misclassified(our["inliers"], inlier)
            cv_wrong = misclassified(mask, inlier)
            report.check(agreement < 0.5, f"{name} {method}: homographies differ by {agreement:.3f} px RMS")
            report.check(our_error <= cv_error * SLACK,
                         f"{name} {method}: our transfer error {our_error:.4f} px > OpenCV's {cv_error:.4f}")
            report.check(our_wrong <= cv_wrong + 1,
                         f"{name} {method}: we misclassify {our_wrong}, OpenCV {cv_wrong}")
            cv_iterations = (stopping_count(sample_conf, int(np.sum(mask)), len(a), 4, cap)
                             if method == "ransac" else
                             stopping_count(sample_conf, math.ceil(0.55 * len(a)), len(a), 4, cap))
            report.add(f"findHomography {method.upper()}", agreement=agreement, ours=our_error,
                       opencv=cv_error, our_wrong=our_wrong, cv_wrong=cv_wrong,
                       our_iterations=our["iterations"], cv_iterations=cv_iterations,
                       our_seconds=our["seconds"], cv_seconds=seconds)
    elif kind == "scene":
        inlier = truth["inlier"]
        # Fundamental matrix.
        our = ours["fundamental"]
        seconds, (f, mask) = theirs["fundamental"]
        our_clean = rms(sampson(our["matrix"], truth["clean_a"], truth["clean_b"]))
        cv_clean = rms(sampson(f[:3], truth["clean_a"], truth["clean_b"]))
        our_error = rms(sampson(our["matrix"], a[inlier], b[inlier]))
        cv_error = rms(sampson(f[:3], a[inlier], b[inlier]))
        our_wrong = misclassified(our["inliers"], inlier)
        cv_wrong = misclassified(mask, inlier)
        report.check(our_clean < 1.0 and cv_clean < 1.0,
                     f"{name} F: noise-free Sampson RMS ours {our_clean:.3f}, OpenCV {cv_clean:.3f} px")
        report.check(our_error <= cv_error * SLACK,
                     f"{name} F: our Sampson error {our_error:.4f} px > OpenCV's {cv_error:.4f}")
        report.check(our_wrong <= cv_wrong + 1, f"{name} F: we misclassify {our_wrong}, OpenCV {cv_wrong}")
        report.add("findFundamentalMat FM_RANSAC", agreement=max(our_clean, cv_clean), ours=our_error,
                   opencv=cv_error, our_wrong=our_wrong, cv_wrong=cv_wrong,
                   our_iterations=our["iterations"],
                   cv_iterations=stopping_count(0.99, int(np.sum(mask)), len(a), 7, 1000),
                   our_seconds=our["seconds"], cv_seconds=seconds)
        # Essential matrix and pose.
        our = ours["essential"]
        seconds, (e, mask) = theirs["essential"]
        na, nb = normalized_points(a[inlier]), normalized_points(b[inlier])
        our_error = rms(sampson(our["matrix"], na, nb)) * FOCAL
        cv_error = rms(sampson(e[:3], na, nb)) * FOCAL
        our_wrong = misclassified(our["inliers"], inlier)
        cv_wrong = misclassified(mask, inlier)
        pose = ours["recover_pose"]
        pose_seconds, (_, r, t, pose_mask) = theirs["recover_pose"]
        our_r = np.array(pose["rotation"]).reshape(3, 3)
        rotation_gap = rotation_angle_degrees(our_r @ r.T)
        direction_gap = angle_degrees(pose["translation"], t)
        our_truth = (rotation_angle_degrees(our_r @ truth["rotation"].T),
                     angle_degrees(pose["translation"], truth["t"]))
        cv_truth = (rotation_angle_degrees(r @ truth["rotation"].T), angle_degrees(t, truth["t"]))
        report.check(rotation_gap < 1.0 and direction_gap < 6.0,
                     f"{name} E: poses differ by {rotation_gap:.3f} deg, direction {direction_gap:.3f} deg")
        report.check(our_truth[0] < 0.3 and our_truth[1] < 2.0,
                     f"{name} E: our pose is {our_truth[0]:.3f} deg, direction {our_truth[1]:.3f} deg off")
        report.check(our_error <= cv_error * SLACK,
                     f"{name} E: our Sampson error {our_error:.4f} px > OpenCV's {cv_error:.4f}")
        report.check(our_wrong <= cv_wrong + 1, f"{name} E: we misclassify {our_wrong}, OpenCV {cv_wrong}")
        report.add("findEssentialMat RANSAC", agreement=rotation_gap, direction=direction_gap,
                   our_truth=our_truth, cv_truth=cv_truth, ours=our_error, opencv=cv_error,
                   our_wrong=our_wrong, cv_wrong=cv_wrong, our_iterations=our["iterations"],
                   cv_iterations=stopping_count(0.999, int(np.sum(mask)), len(a), 5, 1000),
                   our_seconds=our["seconds"], cv_seconds=seconds)
        report.add("recoverPose", our_count=pose["inlier_count"], cv_count=int(np.sum(pose_mask > 0)),
                   our_seconds=pose["seconds"], cv_seconds=pose_seconds)
    elif kind == "eight_point":
        our = ours["eight_point"]
        seconds, (f, _) = theirs["eight_point"]
        ours_f = np.array(our["matrix"]).reshape(3, 3)
        ours_f, cv_f = ours_f / np.linalg.norm(ours_f), f / np.linalg.norm(f)
        gap = min(np.linalg.norm(ours_f - cv_f), np.linalg.norm(ours_f + cv_f))
        report.check(gap < 1e-6, f"{name}: FM_8POINT and ours differ by {gap:.2e} relative")
        report.add("findFundamentalMat FM_8POINT", agreement=gap, our_seconds=our["seconds"], cv_seconds=seconds)
    elif kind == "triangulate":
        our = ours["triangulate"]
        seconds, homogeneous = theirs["triangulate"]
        cv_points = (homogeneous[:3] / homogeneous[3]).T
        our_points = np.array([p["point"] for p in our["points"]])
        gap = float(np.max(np.linalg.norm(our_points - cv_points, axis=1) / np.linalg.norm(cv_points, axis=1)))
        report.check(gap < 1e-6, f"{name}: triangulated points differ by {gap:.2e} relative")
        report.add("triangulatePoints", agreement=gap, our_seconds=our["seconds"], cv_seconds=seconds)
        our = ours["correct_matches"]
        seconds, (new_a, new_b) = theirs["correct_matches"]
        gap = float(max(np.max(np.abs(np.array(our["points_a"]) - new_a.reshape(-1, 2))),
                        np.max(np.abs(np.array(our["points_b"]) - new_b.reshape(-1, 2)))))
        report.check(gap < 1e-6, f"{name}: corrected matches differ by {gap:.2e} px")
        report.add("correctMatches", agreement=gap, our_seconds=our["seconds"], cv_seconds=seconds)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--example", type=Path,
                        default=REPO / "target" / "release" / "examples" / "geometry_solve")
    parser.add_argument("--problems", type=int, default=4)
    parser.add_argument("--points", type=int, default=200)
    parser.add_argument("--noise", type=float, default=0.5)
    parser.add_argument("--outliers", type=float, default=0.25)
    parser.add_argument("--calls", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    if not args.example.exists():
        sys.exit(f"{args.example} is missing: cargo build --release -p stereocal-vision --example geometry_solve")

    cv2.setNumThreads(1)
    problems = make_problems(args)
    theirs = {p["name"]: opencv(p, args.calls, args.repeats) for p in problems}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "problems.json"
        camera = {"width": WIDTH, "height": HEIGHT, "fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2]}
        serializable = [{k: v for k, v in p.items() if k != "truth"} for p in problems]
        path.write_text(json.dumps({"camera": camera, "problems": serializable}))
        done = subprocess.run([str(args.example), str(path), "--calls", str(args.calls),
                               "--repeats", str(args.repeats)], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"geometry_solve failed:\n{done.stderr}")
    ours = {p["name"]: p["results"] for p in json.loads(done.stdout)["problems"]}

    report = Report()
    for problem in problems:
        compare(problem, ours[problem["name"]], theirs[problem["name"]], report)

    print(f"OpenCV {cv2.__version__}; {args.problems} problems per kind, {args.points} correspondences, "
          f"{args.noise} px noise, {args.outliers:.0%} outliers; one thread each; median over "
          f"{args.repeats} batches of {args.calls} calls")
    for solver, rows in report.rows.items():
        ours_us = statistics.median(r["our_seconds"] for r in rows) * 1e6
        cv_us = statistics.median(r["cv_seconds"] for r in rows) * 1e6
        print(f"\n{solver}")
        print(f"    time per call: ours {ours_us:9.1f} us, OpenCV {cv_us:9.1f} us, ratio OpenCV/ours "
              f"{cv_us / ours_us:5.2f}x")
        if "ours" in rows[0]:
            print("    error on the true inliers, px RMS (ours / OpenCV): " +
                  ", ".join(f"{r['ours']:.4f}/{r['opencv']:.4f}" for r in rows))
            print("    misclassified correspondences (ours / OpenCV): " +
                  ", ".join(f"{r['our_wrong']}/{r['cv_wrong']}" for r in rows))
            print("    iterations (ours / OpenCV's stopping count): " +
                  ", ".join(f"{r['our_iterations']}/{r['cv_iterations']}" for r in rows))
        if "direction" in rows[0]:
            print("    ours vs OpenCV: rotation " + ", ".join(f"{r['agreement']:.4f}" for r in rows) +
                  " deg; translation direction " + ", ".join(f"{r['direction']:.3f}" for r in rows) + " deg")
            print("    vs truth (rotation, direction, deg), ours / OpenCV: " + ", ".join(
                f"({r['our_truth'][0]:.3f}, {r['our_truth'][1]:.2f})/({r['cv_truth'][0]:.3f}, {r['cv_truth'][1]:.2f})"
                for r in rows))
        elif "our_count" in rows[0]:
            print("    points in front (ours / OpenCV): " +
                  ", ".join(f"{r['our_count']}/{r['cv_count']}" for r in rows))
        elif solver.startswith("findHomography"):
            print("    transfer of the noise-free points, ours vs OpenCV, px RMS: " +
                  ", ".join(f"{r['agreement']:.4f}" for r in rows))
        elif solver.startswith("findFundamentalMat FM_RANSAC"):
            print("    noise-free Sampson RMS, worse of the two, px: " +
                  ", ".join(f"{r['agreement']:.4f}" for r in rows))
        else:
            print("    largest difference: " + ", ".join(f"{r['agreement']:.2e}" for r in rows))
    for failure in report.failures:
        print("FAILED:", failure)
    if report.failures:
        sys.exit(1)
    print("\ngeometry: all checks against OpenCV passed")


if __name__ == "__main__":
    main()
