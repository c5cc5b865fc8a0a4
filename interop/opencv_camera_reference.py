#!/usr/bin/env python3
"""Reference values from OpenCV for stereocal's camera models and stereo rectification.

Computes, for a few fixed cameras and stereo rigs: projectPoints, undistortPoints (with
OpenCV's default 5 iterations and with many), getOptimalNewCameraMatrix (alpha 0, 0.5,
1), stereoRectify (horizontal and vertical rigs, alpha -1/0/1) and the fisheye variants,
and writes them to vision/tests/fixtures/opencv_camera_reference.json, which the Rust
tests in vision/tests/camera_opencv.rs and vision/tests/stereo_rectify_opencv.rs read.

OpenCV undistorts image points with a fixed number of fixed-point iterations (5 in
getOptimalNewCameraMatrix and stereoRectify, in single precision for stereoRectify's
four corners), which is inexact at strong distortion. So besides OpenCV's own outputs
the fixture holds "converged" values: OpenCV's very algorithm re-run here with every
point undistorted to convergence (Newton on OpenCV's own projectPoints). The script
first checks that this re-implementation, fed OpenCV's inexact undistortion, reproduces
OpenCV's outputs, so the converged values are OpenCV's semantics without its
undistortion error.

Run with the project's virtual environment:
    .venv/bin/python interop/opencv_camera_reference.py
"""

import json
import os
import sys

import cv2
import numpy as np

OUT = os.path.join(
    os.path.dirname(os.path.abspath(__file__)),
    "..",
    "vision",
    "tests",
    "fixtures",
    "opencv_camera_reference.json",
)

CAMERAS = {
    # A wide lens, moderate barrel distortion.
    "wide_plumb_bob": dict(width=640, height=480, fx=600.0, fy=606.0, cx=321.7, cy=238.4,
                           model="plumb_bob", coeffs=[-0.28, 0.09, 0.0011, -0.0007, -0.012]),
    # The right camera of the horizontal rig: close to the left one, not identical.
    "wide_plumb_bob_right": dict(width=640, height=480, fx=603.5, fy=604.0, cx=317.9, cy=242.6,
                                 model="plumb_bob", coeffs=[-0.27, 0.085, -0.0006, 0.0009, -0.010]),
    # Strong barrel distortion: the image corners lie just inside the fold of the radial
    # profile, where 5 fixed-point iterations are pixels off.
    "strong_plumb_bob": dict(width=1280, height=960, fx=640.0, fy=646.4, cx=646.8, cy=475.4,
                             model="plumb_bob", coeffs=[-0.30, 0.10, 0.0012, -0.0008, -0.012]),
    # Coefficients typical of a wide lens calibrated with the rational model.
    "rational": dict(width=1280, height=800, fx=480.0, fy=484.8, cx=646.8, cy=395.4,
                     model="rational_polynomial",
                     coeffs=[1.6, 0.35, 0.0007, -0.0004, 0.008, 2.0, 0.9, 0.06]),
    "rational_right": dict(width=1280, height=800, fx=482.0, fy=483.0, cx=641.1, cy=401.9,
                           model="rational_polynomial",
                           coeffs=[1.55, 0.33, -0.0005, 0.0006, 0.007, 1.95, 0.88, 0.055]),
    # Fisheye whose image corners are about 85 degrees off axis.
    "fisheye": dict(width=1280, height=1024, fx=520.0, fy=521.5, cx=643.2, cy=509.7,
                    model="equidistant", coeffs=[0.04, -0.012, 0.003, -0.0004]),
    "fisheye_right": dict(width=1280, height=1024, fx=518.0, fy=518.5, cx=636.4, cy=514.1,
                          model="equidistant", coeffs=[0.038, -0.011, 0.0028, -0.00035]),
}

RIGS = {
    "horizontal": dict(left="wide_plumb_bob", right="wide_plumb_bob_right",
                       rvec=[0.011, -0.024, 0.006], tvec=[-0.12, 0.0031, 0.0012]),
    "vertical": dict(left="wide_plumb_bob", right="wide_plumb_bob_right",
                     rvec=[-0.018, 0.007, 0.012], tvec=[0.0024, -0.095, 0.0027]),
    "rational_horizontal": dict(left="rational", right="rational_right",
                                rvec=[0.006, 0.015, -0.004], tvec=[-0.065, -0.0012, 0.0008]),
    "fisheye_horizontal": dict(left="fisheye", right="fisheye_right",
                               rvec=[0.009, -0.017, 0.004], tvec=[-0.11, 0.0021, -0.0015]),
}

HIGH_ITERATIONS = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 1000, 1e-16)


def k_matrix(c):
    return np.array([[c["fx"], 0.0, c["cx"]], [0.0, c["fy"], c["cy"]], [0.0, 0.0, 1.0]])


def d_vector(c):
    return np.array(c["coeffs"], dtype=np.float64)


def is_fisheye(c):
    return c["model"] == "equidistant"


def project(c, points):
    """Pixels of camera-frame points, with OpenCV's own projection."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 1, 3)
    if is_fisheye(c):
        out, _ = cv2.fisheye.projectPoints(pts, np.zeros(3), np.zeros(3), k_matrix(c), d_vector(c))
    else:
        out, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), k_matrix(c), d_vector(c))
    return out.reshape(-1, 2)


def reprojection_px(c, pixels, normalized):
    rays = np.hstack([normalized, np.ones((len(normalized), 1))])
    return np.linalg.norm(project(c, rays) - pixels, axis=1)


def undistort_opencv(c, pixels, criteria=None):
    pts = np.asarray(pixels, dtype=np.float64).reshape(-1, 1, 2)
    if is_fisheye(c):
        if criteria is None:
            out = cv2.fisheye.undistortPoints(pts, k_matrix(c), d_vector(c))
        else:
            out = cv2.fisheye.undistortPoints(pts, k_matrix(c), d_vector(c), criteria=criteria)
    elif criteria is None:
        out = cv2.undistortPoints(pts, k_matrix(c), d_vector(c))
    else:
        out = cv2.undistortPointsIter(pts, k_matrix(c), d_vector(c), np.eye(3), np.eye(3), criteria)
    return out.reshape(-1, 2)


def undistort_exact(c, pixels):
    """Undistorted normalized points refined by Newton on OpenCV's projection until they
    reproject onto the pixels to 1e-9 px."""
    pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    best = undistort_opencv(c, pixels, HIGH_ITERATIONS)
    default = undistort_opencv(c, pixels)
    out = np.empty_like(best)
    for i, pixel in enumerate(pixels):
        candidates = [best[i], default[i], (pixel - [c["cx"], c["cy"]]) / [c["fx"], c["fy"]]]
        x = min(candidates, key=lambda p: reprojection_px(c, pixel[None], p[None])[0])
        for _ in range(100):
            r = project(c, [[x[0], x[1], 1.0]])[0] - pixel
            if np.linalg.norm(r) < 1e-10:
                break
            h = 1e-7
            jac = np.empty((2, 2))
            for j in range(2):
                step = np.zeros(2)
                step[j] = h
                plus = project(c, [[*(x + step), 1.0]])[0]
                minus = project(c, [[*(x - step), 1.0]])[0]
                jac[:, j] = (plus - minus) / (2 * h)
            x = x - np.linalg.solve(jac, r)
        error = reprojection_px(c, pixel[None], x[None])[0]
        assert error < 1e-9, (c, pixel, error)
        out[i] = x
    return out


def image_grid(c, nx=17, ny=13):
    xs = np.linspace(0, c["width"] - 1, nx)
    ys = np.linspace(0, c["height"] - 1, ny)
    return np.array([[x, y] for y in ys for x in xs])


def points_in_view(c, seed, count=40):
    """Camera-frame points whose pixels cover the image (and a little beyond)."""
    rng = np.random.default_rng(seed)
    pixels = np.column_stack([
        rng.uniform(-0.05, 1.05, count) * (c["width"] - 1),
        rng.uniform(-0.05, 1.05, count) * (c["height"] - 1),
    ])
    normalized = (pixels - [c["cx"], c["cy"]]) / [c["fx"], c["fy"]]
    if is_fisheye(c):
        # Directions up to about 80 degrees off axis.
        normalized = normalized / np.maximum(1.0, np.linalg.norm(normalized, axis=1) / 5.0)[:, None]
    depth = rng.uniform(0.4, 6.0, count)
    return np.column_stack([normalized * depth[:, None], depth])


# --- getOptimalNewCameraMatrix, re-implemented to swap the undistortion --------------

def rectangles(c, undistort, R=None, P=None, n=9):
    """OpenCV's getUndistortRectangles (9x9 grid over the image, double precision)."""
    w, h = c["width"], c["height"]
    grid = [(x * (w - 1) / (n - 1), y * (h - 1) / (n - 1), x, y) for y in range(n) for x in range(n)]
    und = undistort(c, np.array([g[:2] for g in grid]))
    rays = np.hstack([und, np.ones((len(und), 1))])
    M = (np.eye(3) if P is None else P[:, :3]) @ (np.eye(3) if R is None else R)
    q = rays @ M.T
    pts = q[:, :2] / q[:, 2:3]
    ix0, ix1, iy0, iy1 = -np.inf, np.inf, -np.inf, np.inf
    ox0, ox1, oy0, oy1 = np.inf, -np.inf, np.inf, -np.inf
    for (px, py), (_, _, x, y) in zip(pts, grid):
        ox0, ox1, oy0, oy1 = min(ox0, px), max(ox1, px), min(oy0, py), max(oy1, py)
        if x == 0:
            ix0 = max(ix0, px)
        if x == n - 1:
            ix1 = min(ix1, px)
        if y == 0:
            iy0 = max(iy0, py)
        if y == n - 1:
            iy1 = min(iy1, py)
    return (ix0, iy0, ix1 - ix0, iy1 - iy0), (ox0, oy0, ox1 - ox0, oy1 - oy0)


def clip(rect, size):
    x, y, w, h = rect
    x0, y0 = max(x, 0), max(y, 0)
    x1, y1 = min(x + w, size[0]), min(y + h, size[1])
    return [x0, y0, x1 - x0, y1 - y0] if x1 > x0 and y1 > y0 else [0, 0, 0, 0]


def optimal_new_camera_matrix(c, alpha, new_size, undistort):
    inner, outer = rectangles(c, undistort)
    W, H = new_size
    fx0, fy0 = (W - 1) / inner[2], (H - 1) / inner[3]
    cx0, cy0 = -fx0 * inner[0], -fy0 * inner[1]
    fx1, fy1 = (W - 1) / outer[2], (H - 1) / outer[3]
    cx1, cy1 = -fx1 * outer[0], -fy1 * outer[1]
    K = np.array([[fx0 * (1 - alpha) + fx1 * alpha, 0, cx0 * (1 - alpha) + cx1 * alpha],
                  [0, fy0 * (1 - alpha) + fy1 * alpha, cy0 * (1 - alpha) + cy1 * alpha],
                  [0, 0, 1]])
    inner, _ = rectangles(c, undistort, P=K)
    roi = clip([int(np.rint(v)) for v in inner], new_size)
    return K, roi


# --- stereoRectify, re-implemented to swap the undistortion ---------------------------

def stereo_rectify(cl, cr, R, T, zero_disparity, alpha, new_size, undistort, corner_dtype):
    om, _ = cv2.Rodrigues(R)
    r_r, _ = cv2.Rodrigues(om * -0.5)
    t = r_r @ T
    idx = 0 if abs(t[0]) > abs(t[1]) else 1
    c = t[idx]
    uu = np.zeros(3)
    uu[idx] = 1 if c > 0 else -1
    ww = np.cross(t, uu)
    nw = np.linalg.norm(ww)
    if nw > 0:
        ww *= np.arccos(abs(c) / np.linalg.norm(t)) / nw
    wR, _ = cv2.Rodrigues(ww)
    R1 = wR @ r_r.T
    R2 = wR @ r_r
    t = R2 @ T
    nx, ny = cl["width"], cl["height"]
    new_size = new_size or (nx, ny)
    ratio = (new_size[0] / nx / 2) if idx == 1 else (new_size[1] / ny / 2)
    key = "fx" if idx == 1 else "fy"
    fc = (cl[key] + cr[key]) * ratio
    cc = []
    for cam, Rk in ((cl, R1), (cr, R2)):
        corners = np.array([[0, 0], [nx - 1, 0], [0, ny - 1], [nx - 1, ny - 1]], dtype=corner_dtype)
        und = undistort(cam, corners).astype(corner_dtype).astype(np.float64)
        q = np.hstack([und, np.ones((4, 1))]) @ Rk.T
        proj = (fc * q[:, :2] / q[:, 2:3]).astype(corner_dtype).astype(np.float64)
        avg = proj.mean(axis=0)
        cc.append([(nx - 1) / 2 - avg[0], (ny - 1) / 2 - avg[1]])
    cc = np.array(cc)
    if zero_disparity:
        cc[:] = cc.mean(axis=0)
    elif idx == 0:
        cc[:, 1] = cc[:, 1].mean()
    else:
        cc[:, 0] = cc[:, 0].mean()
    P1 = np.array([[fc, 0, cc[0, 0], 0], [0, fc, cc[0, 1], 0], [0, 0, 1, 0]])
    P2 = np.array([[fc, 0, cc[1, 0], 0], [0, fc, cc[1, 1], 0], [0, 0, 1, 0]])
    P2[idx, 3] = t[idx] * fc
    alpha_eff = min(alpha, 1.0)
    in1, out1 = rectangles(cl, undistort, R1, P1)
    in2, out2 = rectangles(cr, undistort, R2, P2)
    W, H = new_size
    c0 = cc.copy()
    cs = np.array([[W * c0[k, 0] / nx, H * c0[k, 1] / ny] for k in range(2)])
    s = 1.0
    if alpha_eff >= 0:
        def scales(r, k):
            cx, cy = cs[k]
            cx0, cy0 = c0[k]
            return [cx / (cx0 - r[0]), cy / (cy0 - r[1]),
                    (W - 1 - cx) / (r[0] + r[2] - cx0), (H - 1 - cy) / (r[1] + r[3] - cy0)]
        s0 = max(scales(in1, 0) + scales(in2, 1))
        s1 = min(scales(out1, 0) + scales(out2, 1))
        s = s0 * (1 - alpha_eff) + s1 * alpha_eff
    fc *= s
    for P, k in ((P1, 0), (P2, 1)):
        P[0, 0] = P[1, 1] = fc
        P[0, 2], P[1, 2] = cs[k]
    P2[idx, 3] *= s
    rois = []
    for r, k in ((in1, 0), (in2, 1)):
        rois.append(clip([int(np.ceil((r[0] - c0[k, 0]) * s + cs[k, 0])),
                          int(np.ceil((r[1] - c0[k, 1]) * s + cs[k, 1])),
                          int(np.floor(r[2] * s)), int(np.floor(r[3] * s))], new_size))
    shift = (cs[0, 0] - cs[1, 0]) if idx == 0 else (cs[0, 1] - cs[1, 1])
    Q = np.array([[1, 0, 0, -cs[0, 0]], [0, 1, 0, -cs[0, 1]], [0, 0, 0, fc],
                  [0, 0, -1 / t[idx], shift / t[idx]]])
    return dict(R1=R1, R2=R2, P1=P1, P2=P2, Q=Q, roi1=rois[0], roi2=rois[1])


def default_undistort(c, pixels):
    # What cvUndistortPoints does with its default criteria, in the input's precision.
    dtype = pixels.dtype if pixels.dtype == np.float32 else np.float64
    pts = pixels.astype(dtype).reshape(-1, 1, 2)
    return cv2.undistortPoints(pts, k_matrix(c), d_vector(c)).reshape(-1, 2)


def rel_diff(a, b):
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return float(np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b))))


def listify(m):
    return np.asarray(m, dtype=np.float64).tolist()


def main():
    fixture = {
        "opencv_version": cv2.__version__,
        "generator": "interop/opencv_camera_reference.py",
        "cameras": CAMERAS,
        "projections": [],
        "undistortions": [],
        "new_camera_matrices": [],
        "stereo_rectifications": [],
        "fisheye_stereo_rectifications": [],
        "rigs": RIGS,
    }

    for seed, (name, c) in enumerate(CAMERAS.items()):
        points = points_in_view(c, seed)
        fixture["projections"].append(dict(
            camera=name, points=listify(points), pixels=listify(project(c, points))))

        pixels = image_grid(c)
        converged = undistort_opencv(c, pixels, HIGH_ITERATIONS)
        default = undistort_opencv(c, pixels)
        fixture["undistortions"].append(dict(
            camera=name,
            pixels=listify(pixels),
            opencv_iterated=listify(converged),
            opencv_iterated_reprojection_px=listify(reprojection_px(c, pixels, converged)),
            opencv_default=listify(default),
            opencv_default_reprojection_px=listify(reprojection_px(c, pixels, default)),
        ))

    for name in ("wide_plumb_bob", "strong_plumb_bob", "rational"):
        c = CAMERAS[name]
        for alpha in (0.0, 0.5, 1.0):
            for new_size in ((c["width"], c["height"]), (c["width"] * 5 // 4, c["height"] * 5 // 4)):
                K, roi = cv2.getOptimalNewCameraMatrix(
                    k_matrix(c), d_vector(c), (c["width"], c["height"]), alpha, new_size)
                K_re, roi_re = optimal_new_camera_matrix(c, alpha, new_size, default_undistort)
                assert rel_diff(K_re, K) < 1e-12 and list(roi) == roi_re, (name, alpha, K, K_re, roi, roi_re)
                K_conv, roi_conv = optimal_new_camera_matrix(c, alpha, new_size, undistort_exact)
                fixture["new_camera_matrices"].append(dict(
                    camera=name, alpha=alpha, new_size=list(new_size),
                    opencv=dict(K=listify(K), roi=list(roi)),
                    converged=dict(K=listify(K_conv), roi=roi_conv)))

    for name in ("fisheye",):
        c = CAMERAS[name]
        for balance in (0.0, 0.5, 1.0):
            for new_size in ((c["width"], c["height"]), (c["width"] * 3 // 4, c["height"] * 3 // 4)):
                K = cv2.fisheye.estimateNewCameraMatrixForUndistortRectify(
                    k_matrix(c), d_vector(c), (c["width"], c["height"]), np.eye(3),
                    balance=balance, new_size=new_size)
                fixture["new_camera_matrices"].append(dict(
                    camera=name, alpha=balance, new_size=list(new_size),
                    opencv=dict(K=listify(K), roi=None), converged=None))

    zero_disparity = cv2.CALIB_ZERO_DISPARITY
    for rig_name in ("horizontal", "vertical", "rational_horizontal"):
        rig = RIGS[rig_name]
        cl, cr = CAMERAS[rig["left"]], CAMERAS[rig["right"]]
        R, _ = cv2.Rodrigues(np.array(rig["rvec"]))
        T = np.array(rig["tvec"])
        cases = [(True, a, None) for a in (-1.0, 0.0, 0.5, 1.0)]
        cases += [(False, 0.0, None), (True, 0.0, (cl["width"] * 5 // 4, cl["height"] * 5 // 4)),
                  (True, -1.0, (cl["width"] * 3 // 4, cl["height"] * 3 // 4))]
        for zd, alpha, new_size in cases:
            R1, R2, P1, P2, Q, roi1, roi2 = cv2.stereoRectify(
                k_matrix(cl), d_vector(cl), k_matrix(cr), d_vector(cr),
                (cl["width"], cl["height"]), R, T,
                flags=zero_disparity if zd else 0, alpha=alpha,
                newImageSize=new_size or (0, 0))
            ours_cv = stereo_rectify(cl, cr, R, T, zd, alpha, new_size, default_undistort, np.float32)
            for key, value in (("R1", R1), ("R2", R2), ("P1", P1), ("P2", P2), ("Q", Q)):
                assert rel_diff(ours_cv[key], value) < 1e-6, (rig_name, key, value, ours_cv[key])
            assert [list(roi1), list(roi2)] == [ours_cv["roi1"], ours_cv["roi2"]], (rig_name, roi1, roi2, ours_cv)
            conv = stereo_rectify(cl, cr, R, T, zd, alpha, new_size, undistort_exact, np.float64)
            fixture["stereo_rectifications"].append(dict(
                rig=rig_name, zero_disparity=zd, alpha=alpha,
                new_size=list(new_size) if new_size else None,
                opencv=dict(R1=listify(R1), R2=listify(R2), P1=listify(P1), P2=listify(P2),
                            Q=listify(Q), roi1=list(roi1), roi2=list(roi2)),
                converged=dict(P1=listify(conv["P1"]), P2=listify(conv["P2"]), Q=listify(conv["Q"]),
                               roi1=conv["roi1"], roi2=conv["roi2"])))

    rig = RIGS["fisheye_horizontal"]
    cl, cr = CAMERAS[rig["left"]], CAMERAS[rig["right"]]
    R, _ = cv2.Rodrigues(np.array(rig["rvec"]))
    T = np.array(rig["tvec"]).reshape(3, 1)
    for zd, balance, new_size, fov_scale in ((True, 0.0, None, 1.0), (True, 0.5, None, 1.0),
                                             (True, 1.0, None, 1.0), (False, 0.0, None, 1.0),
                                             (True, 0.0, (960, 768), 1.2)):
        R1, R2, P1, P2, Q = cv2.fisheye.stereoRectify(
            k_matrix(cl), d_vector(cl), k_matrix(cr), d_vector(cr),
            (cl["width"], cl["height"]), R, T, flags=zero_disparity if zd else 0,
            newImageSize=new_size or (0, 0), balance=balance, fov_scale=fov_scale)
        fixture["fisheye_stereo_rectifications"].append(dict(
            rig="fisheye_horizontal", zero_disparity=zd, balance=balance,
            new_size=list(new_size) if new_size else None, fov_scale=fov_scale,
            opencv=dict(R1=listify(R1), R2=listify(R2), P1=listify(P1), P2=listify(P2), Q=listify(Q))))

    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    tmp = OUT + ".tmp"
    with open(tmp, "w") as f:
        json.dump(fixture, f, sort_keys=True)
        f.write("\n")
    os.replace(tmp, OUT)
    print(f"wrote {os.path.relpath(OUT)} (OpenCV {cv2.__version__})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
