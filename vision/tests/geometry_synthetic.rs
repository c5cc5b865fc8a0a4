//! Two-view geometry against ground truth: synthetic correspondences from known poses,
//! planes and scenes, with Gaussian pixel noise and gross outliers; the recovered
//! homographies, fundamental and essential matrices, poses, inlier masks and
//! triangulated points are checked against the truth, and degenerate input against
//! clear refusals.
//!
//! Noise is 0.5 px per coordinate; 25 % of the correspondences are outliers drawn
//! uniformly over the image. The tolerances follow from the noise: a model fitted to
//! n ~ 150 inliers has a parameter error of about sigma * sqrt(dof / n), so its error at
//! the inliers is a fraction of sigma (0.1 to 0.2 px), and each bound below is a few
//! times that.

use nalgebra::{
    Isometry3, Matrix3, Matrix3x4, Point2, Point3, Translation3, UnitQuaternion, Vector3,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::geometry::{
    DEFAULT_MAX_DISTANCE, GeometryError, RobustOptions, correct_matches, decompose_homography,
    find_essential, find_fundamental, find_homography, fundamental_8point, recover_pose,
    sampson_distance, triangulate_linear, triangulate_optimal, triangulate_rectified,
    triangulate_stereo, visible_decompositions,
};
use stereocal_vision::rectify::{StereoRectifyOptions, stereo_rectify};

const WIDTH: f64 = 1024.0;
const HEIGHT: f64 = 768.0;
const NOISE_PX: f64 = 0.5;
const OUTLIER_RATIO: f64 = 0.25;
const POINTS: usize = 200;

fn intrinsics() -> Intrinsics {
    Intrinsics {
        fx: 800.0,
        fy: 805.0,
        cx: 515.0,
        cy: 380.0,
    }
}

fn pinhole() -> CameraModel {
    CameraModel {
        width: WIDTH as u32,
        height: HEIGHT as u32,
        intrinsics: intrinsics(),
        distortion: Distortion::none(),
    }
}

fn gaussian(rng: &mut ChaCha8Rng, sigma: f64) -> f64 {
    let u: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    sigma * (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

fn noisy(rng: &mut ChaCha8Rng, p: Point2<f64>) -> Point2<f64> {
    Point2::new(p.x + gaussian(rng, NOISE_PX), p.y + gaussian(rng, NOISE_PX))
}

fn in_image(p: &Point2<f64>) -> bool {
    p.x >= 0.0 && p.x <= WIDTH - 1.0 && p.y >= 0.0 && p.y <= HEIGHT - 1.0
}

fn random_pixel(rng: &mut ChaCha8Rng) -> Point2<f64> {
    Point2::new(
        rng.random_range(0.0..WIDTH - 1.0),
        rng.random_range(0.0..HEIGHT - 1.0),
    )
}

/// The second camera of the two-view scenes: turned by about 9 degrees, moved 0.5 m
/// mostly sideways.
fn b_from_a() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(-0.45, 0.08, 0.12),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.05, -0.14, 0.04)),
    )
}

/// Correspondences of `points` (camera a's frame) seen by both cameras, noisy, with a
/// quarter replaced by outliers (in image b). Returns pixels of a and b, the noise-free
/// pixels, and which are true inliers.
struct Views {
    a: Vec<Point2<f64>>,
    b: Vec<Point2<f64>>,
    clean_a: Vec<Point2<f64>>,
    clean_b: Vec<Point2<f64>>,
    inlier: Vec<bool>,
}

fn views(rng: &mut ChaCha8Rng, points: &[Point3<f64>], pose: &Isometry3<f64>) -> Views {
    let camera = pinhole();
    let mut v = Views {
        a: vec![],
        b: vec![],
        clean_a: vec![],
        clean_b: vec![],
        inlier: vec![],
    };
    for p in points {
        let (Some(a), Some(b)) = (camera.project(p), camera.project(&(pose * p))) else {
            continue;
        };
        if !in_image(&a) || !in_image(&b) {
            continue;
        }
        let outlier = rng.random_range(0.0..1.0) < OUTLIER_RATIO;
        v.a.push(noisy(rng, a));
        v.b.push(if outlier {
            random_pixel(rng)
        } else {
            noisy(rng, b)
        });
        v.clean_a.push(a);
        v.clean_b.push(b);
        v.inlier.push(!outlier);
    }
    v
}

/// Points of a general scene 3 to 8 m in front of camera a.
fn scene(rng: &mut ChaCha8Rng, n: usize) -> Vec<Point3<f64>> {
    (0..n)
        .map(|_| {
            let z = rng.random_range(3.0..8.0);
            Point3::new(
                rng.random_range(-0.55..0.55) * z,
                rng.random_range(-0.4..0.4) * z,
                z,
            )
        })
        .collect()
}

/// The plane of the homography scenes, in camera a's frame: unit normal and distance.
fn plane() -> (Vector3<f64>, f64) {
    (Vector3::new(0.1, -0.2, 1.0).normalize(), 4.0)
}

fn plane_points(rng: &mut ChaCha8Rng, n: usize) -> Vec<Point3<f64>> {
    let (normal, distance) = plane();
    (0..n)
        .map(|_| {
            let ray = Vector3::new(
                rng.random_range(-0.6..0.6),
                rng.random_range(-0.45..0.45),
                1.0,
            );
            Point3::from(ray * (distance / normal.dot(&ray)))
        })
        .collect()
}

fn true_homography() -> Matrix3<f64> {
    let (normal, distance) = plane();
    let pose = b_from_a();
    let k = intrinsics().matrix();
    let h = k
        * (pose.rotation.to_rotation_matrix().matrix()
            + pose.translation.vector * normal.transpose() / distance)
        * k.try_inverse().unwrap();
    h / h[(2, 2)]
}

fn transfer(h: &Matrix3<f64>, p: &Point2<f64>) -> Point2<f64> {
    Point2::from_homogeneous(h * p.to_homogeneous()).unwrap()
}

/// Correspondences the mask gets wrong: (true inliers rejected, outliers accepted).
fn misclassified(mask: &[bool], truth: &[bool]) -> (usize, usize) {
    let rejected = mask.iter().zip(truth).filter(|(m, t)| **t && !**m).count();
    let accepted = mask.iter().zip(truth).filter(|(m, t)| !**t && **m).count();
    (rejected, accepted)
}

fn angle_between(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.angle(b)
}

#[test]
fn find_homography_recovers_a_plane_through_outliers() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let points = plane_points(&mut rng, POINTS);
    let v = views(&mut rng, &points, &b_from_a());
    let truth = true_homography();
    for options in [RobustOptions::ransac(3.0), RobustOptions::lmeds()] {
        let found = find_homography(&v.a, &v.b, &options).unwrap();
        // The fitted map at the true points: the transfer residual has noise
        // sigma * sqrt(2) = 0.7 px, and 8 parameters fitted to ~150 inliers err at the
        // points by about 0.7 * sqrt(8 / 150) = 0.16 px RMS, more towards the edges.
        let errors: Vec<f64> = v
            .clean_a
            .iter()
            .map(|p| (transfer(&found.image_b_from_image_a, p) - transfer(&truth, p)).norm())
            .collect();
        let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
        let worst = errors.iter().copied().fold(0.0, f64::max);
        assert!(
            rms < 0.3 && worst < 0.8,
            "{:?}: {rms} px RMS, {worst} px",
            options.method
        );
        // 3 px is 6 sigma for an inlier; a uniform outlier lands within 3 px of its
        // transfer with probability ~4e-5.
        let (rejected, accepted) = misclassified(&found.inliers, &v.inlier);
        assert!(
            rejected <= 2 && accepted == 0,
            "{:?}: {rejected} {accepted}",
            options.method
        );
        assert_eq!(
            found.inlier_count,
            found.inliers.iter().filter(|&&i| i).count()
        );
        // The transfer error of inliers carries the noise of both images: about
        // sigma * sqrt(2) RMS.
        assert!(found.rms_px > 0.4 && found.rms_px < 1.0, "{}", found.rms_px);
        assert!(found.iterations > 0);
    }
}

#[test]
fn find_homography_is_deterministic() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let points = plane_points(&mut rng, POINTS);
    let v = views(&mut rng, &points, &b_from_a());
    let first = find_homography(&v.a, &v.b, &RobustOptions::ransac(3.0)).unwrap();
    let second = find_homography(&v.a, &v.b, &RobustOptions::ransac(3.0)).unwrap();
    assert_eq!(first, second);
}

#[test]
fn homography_decomposition_holds_the_true_pose_and_plane() {
    let truth = b_from_a();
    let (normal, distance) = plane();
    let solutions = decompose_homography(&true_homography(), &intrinsics(), &intrinsics()).unwrap();
    assert_eq!(solutions.len(), 4);
    let matches = |s: &stereocal_vision::geometry::HomographyDecomposition| {
        s.camera_b_from_camera_a.rotation.angle_to(&truth.rotation) < 1e-9
            && (s.camera_b_from_camera_a.translation.vector - truth.translation.vector / distance)
                .norm()
                < 1e-9
            && (s.normal_in_a - normal).norm() < 1e-9
    };
    assert!(solutions.iter().any(matches), "{solutions:?}");
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let points = plane_points(&mut rng, 30);
    let camera = pinhole();
    let a: Vec<Point2<f64>> = points.iter().map(|p| camera.project(p).unwrap()).collect();
    let b: Vec<Point2<f64>> = points
        .iter()
        .map(|p| camera.project(&(truth * p)).unwrap())
        .collect();
    let visible = visible_decompositions(&solutions, &intrinsics(), &a, &intrinsics(), &b).unwrap();
    assert!(!visible.is_empty() && visible.len() <= 2, "{visible:?}");
    assert!(visible.iter().any(matches));
    // A pure rotation: one solution, no translation, no plane.
    let k = intrinsics().matrix();
    let rotation = k * truth.rotation.to_rotation_matrix().matrix() * k.try_inverse().unwrap();
    let pure = decompose_homography(&(rotation * 3.0), &intrinsics(), &intrinsics()).unwrap();
    assert_eq!(pure.len(), 1);
    assert!(
        pure[0]
            .camera_b_from_camera_a
            .rotation
            .angle_to(&truth.rotation)
            < 1e-9
    );
    assert_eq!(pure[0].normal_in_a, Vector3::zeros());
}

#[test]
fn fundamental_from_a_general_scene() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let points = scene(&mut rng, POINTS);
    let pose = b_from_a();
    let v = views(&mut rng, &points, &pose);
    // The 8-point algorithm on exact correspondences is exact.
    let exact = fundamental_8point(&v.clean_a, &v.clean_b).unwrap();
    for (a, b) in v.clean_a.iter().zip(&v.clean_b) {
        assert!(sampson_distance(&exact, a, b) < 1e-8);
    }
    for options in [RobustOptions::ransac(1.5), RobustOptions::lmeds()] {
        let found = find_fundamental(&v.a, &v.b, &options).unwrap();
        let f = found.fundamental;
        assert!(f.determinant().abs() < 1e-12 * f.norm().powi(3));
        // The epipolar geometry at the true points: a fraction of the noise.
        let rms = (v
            .clean_a
            .iter()
            .zip(&v.clean_b)
            .map(|(a, b)| sampson_distance(&f, a, b).powi(2))
            .sum::<f64>()
            / v.clean_a.len() as f64)
            .sqrt();
        assert!(rms < 0.25, "{:?}: {rms} px", options.method);
        // An inlier's Sampson distance is about N(0, sigma): 1.5 px is 3 sigma. An
        // outlier falls within the band around its epipolar line with probability of
        // about 1 %.
        let (rejected, accepted) = misclassified(&found.inliers, &v.inlier);
        let n = v.a.len();
        assert!(
            rejected + accepted <= n * 3 / 100,
            "{:?}: {rejected} {accepted}",
            options.method
        );
    }
}

#[test]
fn essential_and_pose_from_a_general_scene() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let points = scene(&mut rng, POINTS);
    let truth = b_from_a();
    let v = views(&mut rng, &points, &truth);
    let camera = pinhole();
    for options in [RobustOptions::ransac(1.0), RobustOptions::lmeds()] {
        let found = find_essential(&camera, &v.a, &camera, &v.b, &options).unwrap();
        let (rejected, accepted) = misclassified(&found.inliers, &v.inlier);
        let n = v.a.len();
        // 1 px is 2 sigma of the Sampson distance: about 5 % of the inliers fall
        // outside; a few outliers fall inside the band.
        assert!(
            rejected <= n / 10 && accepted <= n / 50,
            "{:?}: {rejected} {accepted}",
            options.method
        );
        let pose = recover_pose(
            &found.essential,
            &camera,
            &v.a,
            &camera,
            &v.b,
            Some(&found.inliers),
            DEFAULT_MAX_DISTANCE,
        )
        .unwrap();
        // 0.5 px noise at f = 800 over ~150 points spread across the image: the rotation
        // is good to a few hundredths of a degree, the direction of the 0.47 m baseline
        // (seen from 3 to 8 m) to a few tenths.
        let rotation_error = pose
            .camera_b_from_camera_a
            .rotation
            .angle_to(&truth.rotation)
            .to_degrees();
        let direction_error = angle_between(
            &pose.camera_b_from_camera_a.translation.vector,
            &truth.translation.vector,
        )
        .to_degrees();
        assert!(
            rotation_error < 0.1,
            "{:?}: {rotation_error} deg",
            options.method
        );
        assert!(
            direction_error < 1.0,
            "{:?}: {direction_error} deg",
            options.method
        );
        assert!((pose.camera_b_from_camera_a.translation.vector.norm() - 1.0).abs() < 1e-12);
        // Every considered inlier is in front of both cameras for the true pose.
        assert!(
            pose.inlier_count + 2 >= found.inlier_count,
            "{} {}",
            pose.inlier_count,
            found.inlier_count
        );
        assert!(
            pose.inliers
                .iter()
                .zip(&found.inliers)
                .all(|(p, f)| !p || *f)
        );
    }
}

#[test]
fn triangulation_from_a_calibrated_stereo_pair() {
    let left = CameraModel {
        distortion: Distortion::PlumbBob {
            coeffs: [-0.25, 0.08, 0.001, -0.0005, 0.0],
        },
        ..pinhole()
    };
    let right = CameraModel {
        intrinsics: Intrinsics {
            fx: 810.0,
            fy: 812.0,
            cx: 505.0,
            cy: 390.0,
        },
        distortion: Distortion::PlumbBob {
            coeffs: [-0.2, 0.05, -0.001, 0.0008, 0.0],
        },
        ..pinhole()
    };
    let right_from_left = Isometry3::new(
        Vector3::new(-0.12, 0.002, 0.001),
        Vector3::new(0.01, -0.02, 0.005),
    );
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let points: Vec<Point3<f64>> = scene(&mut rng, 100).into_iter().map(|p| p * 0.4).collect();
    let (mut pl, mut pr, mut kept) = (vec![], vec![], vec![]);
    for p in &points {
        if let (Some(l), Some(r)) = (left.project(p), right.project(&(right_from_left * p))) {
            pl.push(l);
            pr.push(r);
            kept.push(*p);
        }
    }
    // Exact pixels: exact points, zero errors.
    let exact = triangulate_stereo(&left, &right, &right_from_left, &pl, &pr).unwrap();
    for (t, p) in exact.iter().zip(&kept) {
        let t = t.unwrap();
        assert!(
            (t.point - p).norm() < 1e-7 * p.coords.norm(),
            "{} vs {p}",
            t.point
        );
        assert!(t.error_a_px < 1e-6 && t.error_b_px < 1e-6);
    }
    // Noisy pixels: the disparity has noise sigma * sqrt(2), so the distance along the
    // ray has |p| z / (f b) times that; 5 of its standard deviations are the bound.
    let noisy_l: Vec<Point2<f64>> = pl.iter().map(|p| noisy(&mut rng, *p)).collect();
    let noisy_r: Vec<Point2<f64>> = pr.iter().map(|p| noisy(&mut rng, *p)).collect();
    let found = triangulate_stereo(&left, &right, &right_from_left, &noisy_l, &noisy_r).unwrap();
    for (t, p) in found.iter().zip(&kept) {
        let t = t.unwrap();
        let bound =
            5.0 * p.coords.norm() * p.z / (800.0 * 0.12) * NOISE_PX * std::f64::consts::SQRT_2;
        assert!((t.point - p).norm() < bound, "{} vs {p}", t.point);
        assert!(t.error_a_px < 5.0 * NOISE_PX && t.error_b_px < 5.0 * NOISE_PX);
    }
    // The rectified pair: P1, P2 triangulate into the rectified left frame.
    let rectification = stereo_rectify(
        &left,
        &right,
        &right_from_left,
        &StereoRectifyOptions::default(),
    )
    .unwrap();
    // P1 and P2 both take points of the rectified left frame (P2 holds the baseline).
    let in_rectified: Vec<Point3<f64>> = kept
        .iter()
        .map(|p| rectification.left_rectified_from_original * p)
        .collect();
    let image = |projection: &Matrix3x4<f64>| -> Vec<Point2<f64>> {
        in_rectified
            .iter()
            .map(|p| Point2::from_homogeneous(projection * p.to_homogeneous()).unwrap())
            .collect()
    };
    let (rl, rr) = (
        image(&rectification.left_projection),
        image(&rectification.right_projection),
    );
    let found = triangulate_rectified(&rectification, &rl, &rr).unwrap();
    for (t, expected) in found.iter().zip(&in_rectified) {
        let t = t.unwrap();
        assert!(
            (t.point - expected).norm() < 1e-7 * expected.coords.norm(),
            "{} vs {expected}",
            t.point
        );
    }
}

#[test]
fn optimal_triangulation_fits_better_than_linear() {
    let mut rng = ChaCha8Rng::seed_from_u64(51);
    let pose = b_from_a();
    let k = intrinsics().matrix();
    let pa = k * Matrix3x4::identity();
    let pb = k * pose.to_matrix().fixed_rows::<3>(0);
    let points = scene(&mut rng, 100);
    let camera = pinhole();
    let a: Vec<Point2<f64>> = points
        .iter()
        .map(|p| noisy(&mut rng, camera.project(p).unwrap()))
        .collect();
    let b: Vec<Point2<f64>> = points
        .iter()
        .map(|p| noisy(&mut rng, camera.project(&(pose * p)).unwrap()))
        .collect();
    let linear = triangulate_linear(&pa, &pb, &a, &b).unwrap();
    let optimal = triangulate_optimal(&pa, &pb, &a, &b).unwrap();
    let cost = |t: &Option<stereocal_vision::geometry::TriangulatedPoint>| {
        let t = t.unwrap();
        t.error_a_px.powi(2) + t.error_b_px.powi(2)
    };
    for (l, o) in linear.iter().zip(&optimal) {
        assert!(cost(o) <= cost(l) + 1e-9, "{} > {}", cost(o), cost(l));
    }
    // The corrected matches satisfy the epipolar constraint exactly and move by the
    // noise (each coordinate of each point by about sigma / sqrt(2) along the normal).
    let f = k.try_inverse().unwrap().transpose()
        * pose.translation.vector.cross_matrix()
        * pose.rotation.to_rotation_matrix().matrix()
        * k.try_inverse().unwrap();
    let corrected = correct_matches(&f, &a, &b).unwrap();
    for ((ca, cb), (a, b)) in corrected
        .points_a
        .iter()
        .zip(&corrected.points_b)
        .zip(a.iter().zip(&b))
    {
        assert!(sampson_distance(&f, ca, cb) < 1e-9);
        assert!((ca - a).norm() < 5.0 * NOISE_PX && (cb - b).norm() < 5.0 * NOISE_PX);
    }
}

#[test]
fn degenerate_input_is_refused() {
    let camera = pinhole();
    let line: Vec<Point2<f64>> = (0..30)
        .map(|i| Point2::new(10.0 * i as f64, 5.0 * i as f64 + 3.0))
        .collect();
    let shifted: Vec<Point2<f64>> = line
        .iter()
        .map(|p| p + Vector3::new(4.0, -2.0, 0.0).xy())
        .collect();
    assert!(find_homography(&line, &shifted, &RobustOptions::ransac(3.0)).is_err());
    assert!(find_fundamental(&line, &shifted, &RobustOptions::ransac(1.0)).is_err());
    assert!(
        find_essential(
            &camera,
            &line,
            &camera,
            &shifted,
            &RobustOptions::ransac(1.0)
        )
        .is_err()
    );
    let same = vec![Point2::new(100.0, 100.0); 20];
    assert!(find_homography(&same, &same, &RobustOptions::lmeds()).is_err());
    assert!(find_fundamental(&same, &same, &RobustOptions::lmeds()).is_err());
    assert!(find_essential(&camera, &same, &camera, &same, &RobustOptions::lmeds()).is_err());
    // A planar scene does not determine F.
    let mut rng = ChaCha8Rng::seed_from_u64(61);
    let flat = plane_points(&mut rng, 50);
    let v = views(&mut rng, &flat, &b_from_a());
    assert!(matches!(
        fundamental_8point(&v.clean_a, &v.clean_b),
        Err(GeometryError::Degenerate(_))
    ));
    assert!(matches!(
        find_homography(&line[..3], &shifted[..3], &RobustOptions::ransac(3.0)),
        Err(GeometryError::TooFewPoints { needed: 4, got: 3 })
    ));
    assert!(matches!(
        find_fundamental(&line[..5], &shifted[..6], &RobustOptions::ransac(3.0)),
        Err(GeometryError::MismatchedLengths { a: 5, b: 6 })
    ));
    let mut nan = line.clone();
    nan[3].x = f64::NAN;
    assert!(matches!(
        find_homography(&nan, &shifted, &RobustOptions::ransac(3.0)),
        Err(GeometryError::NonFinite(_))
    ));
    let bad = RobustOptions {
        confidence: 1.0,
        ..RobustOptions::ransac(3.0)
    };
    assert!(matches!(
        find_homography(&v.a, &v.b, &bad),
        Err(GeometryError::InvalidOption(_))
    ));
    assert!(recover_pose(&Matrix3::zeros(), &camera, &v.a, &camera, &v.b, None, 50.0).is_err());
    assert!(decompose_homography(&Matrix3::zeros(), &intrinsics(), &intrinsics()).is_err());
    // Pure outliers: no consensus rather than a model of noise.
    let mut rng = ChaCha8Rng::seed_from_u64(62);
    let a: Vec<Point2<f64>> = (0..100).map(|_| random_pixel(&mut rng)).collect();
    let b: Vec<Point2<f64>> = (0..100).map(|_| random_pixel(&mut rng)).collect();
    let result = find_homography(&a, &b, &RobustOptions::ransac(0.5));
    if let Ok(h) = &result {
        assert!(h.inlier_count < 10, "{}", h.inlier_count);
    }
}
