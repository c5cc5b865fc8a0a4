//! Uncalibrated rectification (`rectify_uncalibrated`) on synthetic pairs: two pinhole
//! cameras of different focal lengths on a verged and rolled rig see a general scene;
//! the homographies from its fundamental matrix must put every matched point, used in
//! the fit or not, on one row. Outliers are left out before the fit, and bad input is
//! refused with the error that names it.

use nalgebra::{Isometry3, Matrix3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::geometry::{
    GeometryError, RobustOptions, find_fundamental, fundamental_8point,
};
use stereocal_vision::rectify::{UncalibratedRectifyError, rectify_uncalibrated};

const SIZE: (u32, u32) = (1024, 768);

fn camera(fx: f64, cx: f64, cy: f64) -> CameraModel {
    CameraModel {
        width: SIZE.0,
        height: SIZE.1,
        intrinsics: Intrinsics {
            fx,
            fy: fx * 1.003,
            cx,
            cy,
        },
        distortion: Distortion::none(),
    }
}

/// A verged rig: the right camera 12 cm to the right, turned 5 degrees towards the left
/// one, rolled 2 degrees and pitched 1, with a different lens.
struct Rig {
    left: CameraModel,
    right: CameraModel,
    right_from_left: Isometry3<f64>,
}

impl Rig {
    fn verged() -> Self {
        let rotation = UnitQuaternion::from_euler_angles(
            1.0_f64.to_radians(),
            -5.0_f64.to_radians(),
            2.0_f64.to_radians(),
        );
        let centre_in_left = Vector3::new(0.12, 0.004, -0.01);
        Self {
            left: camera(820.0, 515.0, 380.0),
            right: camera(760.0, 505.0, 391.0),
            right_from_left: Isometry3::from_parts(
                Translation3::from(-(rotation * centre_in_left)),
                rotation,
            ),
        }
    }

    /// Matched pixels of `count` scene points 1.5 to 6 m away seen by both cameras.
    fn matches(&self, count: usize, seed: u64) -> (Vec<Point2<f64>>, Vec<Point2<f64>>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (mut left, mut right) = (Vec::new(), Vec::new());
        while left.len() < count {
            let z = rng.random_range(1.5..6.0);
            let point = Point3::new(
                rng.random_range(-0.6..0.6) * z,
                rng.random_range(-0.45..0.45) * z,
                z,
            );
            let (Some(l), Some(r)) = (
                self.pixel(&self.left, &point),
                self.pixel(&self.right, &(self.right_from_left * point)),
            ) else {
                continue;
            };
            left.push(l);
            right.push(r);
        }
        (left, right)
    }

    /// The rig's exact fundamental matrix, `K_r^-T [t]x R K_l^-1`, scaled to
    /// `F[(2, 2)] = 1`.
    fn fundamental(&self) -> Matrix3<f64> {
        let inverse_k = |c: &CameraModel| {
            let i = &c.intrinsics;
            Matrix3::new(i.fx, 0.0, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0)
                .try_inverse()
                .unwrap()
        };
        let t = self.right_from_left.translation.vector;
        let r = self
            .right_from_left
            .rotation
            .to_rotation_matrix()
            .into_inner();
        let f = inverse_k(&self.right).transpose() * t.cross_matrix() * r * inverse_k(&self.left);
        f / f[(2, 2)]
    }

    fn pixel(&self, camera: &CameraModel, point: &Point3<f64>) -> Option<Point2<f64>> {
        let p = camera.project(point)?;
        let inside = (0.0..f64::from(SIZE.0) - 1.0).contains(&p.x)
            && (0.0..f64::from(SIZE.1) - 1.0).contains(&p.y);
        inside.then_some(p)
    }
}

fn apply(h: &Matrix3<f64>, p: &Point2<f64>) -> Point2<f64> {
    let q = h * p.to_homogeneous();
    Point2::new(q.x / q.z, q.y / q.z)
}

/// Largest |row difference| of the matches after rectification, pixels.
fn worst_row_offset(
    h_left: &Matrix3<f64>,
    h_right: &Matrix3<f64>,
    left: &[Point2<f64>],
    right: &[Point2<f64>],
) -> f64 {
    left.iter()
        .zip(right)
        .map(|(l, r)| (apply(h_left, l).y - apply(h_right, r).y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn matched_points_share_rows_on_a_verged_rig() {
    let rig = Rig::verged();
    let (left, right) = rig.matches(60, 1);
    let f = rig.fundamental();
    let result = rectify_uncalibrated(&left, &right, &f, SIZE, 1.0).unwrap();
    assert_eq!(result.inlier_count, left.len());
    assert!(result.inliers.iter().all(|&i| i));
    let (h_left, h_right) = (
        result.rectified_left_from_image_left,
        result.rectified_right_from_image_right,
    );
    let used = worst_row_offset(&h_left, &h_right, &left, &right);
    assert!(
        used < 1e-6,
        "rows of the points used differ by up to {used} px"
    );
    // Points the fit never saw share rows too: the rows come from the epipolar geometry.
    let (fresh_left, fresh_right) = rig.matches(200, 2);
    let fresh = worst_row_offset(&h_left, &h_right, &fresh_left, &fresh_right);
    assert!(
        fresh < 1e-6,
        "rows of new points differ by up to {fresh} px"
    );
    // The images stay upright: left to right and top to bottom keep their order.
    let centre = Point2::new(511.0, 383.0);
    for h in [&h_left, &h_right] {
        let right_of = apply(h, &Point2::new(centre.x + 50.0, centre.y)).x - apply(h, &centre).x;
        let below = apply(h, &Point2::new(centre.x, centre.y + 50.0)).y - apply(h, &centre).y;
        assert!(
            right_of > 0.0 && below > 0.0,
            "a rectified image is mirrored"
        );
    }
}

#[test]
fn rows_align_when_f_is_estimated_from_noisy_points() {
    // 0.3 px of noise on every coordinate: F from RANSAC, then the rows of the
    // noise-free points are compared, so that only the estimate's error shows. Fitted
    // to 300 points, F's error at a point is a fraction of the noise; the bound is half
    // the 0.5 px that rectified rows must keep on rendered images.
    let rig = Rig::verged();
    let (left, right) = rig.matches(300, 10);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut noisy = |points: &[Point2<f64>]| -> Vec<Point2<f64>> {
        points
            .iter()
            .map(|p| Point2::new(p.x + gaussian(&mut rng, 0.3), p.y + gaussian(&mut rng, 0.3)))
            .collect()
    };
    let (noisy_left, noisy_right) = (noisy(&left), noisy(&right));
    let f = find_fundamental(&noisy_left, &noisy_right, &RobustOptions::ransac(1.0))
        .unwrap()
        .fundamental;
    let result = rectify_uncalibrated(&noisy_left, &noisy_right, &f, SIZE, 2.0).unwrap();
    let worst = worst_row_offset(
        &result.rectified_left_from_image_left,
        &result.rectified_right_from_image_right,
        &left,
        &right,
    );
    assert!(
        worst < 0.25,
        "rows of the true points differ by up to {worst} px"
    );
}

fn gaussian(rng: &mut ChaCha8Rng, sigma: f64) -> f64 {
    let u: f64 = rng.random_range(f64::MIN_POSITIVE..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    sigma * (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

#[test]
fn disparity_after_rectification_is_small_where_the_fit_was_made() {
    // The shear of the left image is fitted so that matched columns differ least: a
    // rig turned 5 degrees leaves disparities far below the image width.
    let rig = Rig::verged();
    let (left, right) = rig.matches(100, 3);
    let f = rig.fundamental();
    let result = rectify_uncalibrated(&left, &right, &f, SIZE, 1.0).unwrap();
    let worst = left
        .iter()
        .zip(&right)
        .map(|(l, r)| {
            (apply(&result.rectified_left_from_image_left, l).x
                - apply(&result.rectified_right_from_image_right, r).x)
                .abs()
        })
        .fold(0.0, f64::max);
    assert!(worst < 150.0, "disparity up to {worst} px");
}

#[test]
fn points_off_the_epipolar_geometry_are_left_out_first() {
    let rig = Rig::verged();
    let (clean_left, clean_right) = rig.matches(80, 4);
    let f = rig.fundamental();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (mut left, mut right, mut truth) = (Vec::new(), Vec::new(), Vec::new());
    for (i, (l, r)) in clean_left.iter().zip(&clean_right).enumerate() {
        let outlier = i % 4 == 1;
        let shift = if outlier {
            rng.random_range(15.0..40.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 }
        } else {
            0.0
        };
        left.push(*l);
        right.push(Point2::new(r.x, r.y + shift));
        truth.push(!outlier);
    }
    let with_outliers = rectify_uncalibrated(&left, &right, &f, SIZE, 3.0).unwrap();
    assert_eq!(with_outliers.inliers, truth);
    assert_eq!(with_outliers.inlier_count, 60);
    let only_inliers = rectify_uncalibrated(&clean_left, &clean_right, &f, SIZE, 3.0).unwrap();
    let (kept_left, kept_right): (Vec<_>, Vec<_>) = left
        .iter()
        .zip(&right)
        .zip(&truth)
        .filter(|(_, keep)| **keep)
        .map(|((l, r), _)| (*l, *r))
        .unzip();
    let reference = rectify_uncalibrated(&kept_left, &kept_right, &f, SIZE, 3.0).unwrap();
    for (a, b) in [
        (
            with_outliers.rectified_left_from_image_left,
            reference.rectified_left_from_image_left,
        ),
        (
            with_outliers.rectified_right_from_image_right,
            reference.rectified_right_from_image_right,
        ),
    ] {
        assert!((a - b).norm() <= 1e-12 * b.norm(), "{a} differs from {b}");
    }
    // Kept, the outliers pull the left shear away from the inliers' fit.
    let everything = rectify_uncalibrated(&left, &right, &f, SIZE, f64::INFINITY).unwrap();
    assert_eq!(everything.inlier_count, left.len());
    let moved = (everything.rectified_left_from_image_left
        - only_inliers.rectified_left_from_image_left)
        .norm();
    assert!(moved > 1e-6, "outliers kept changed nothing ({moved})");
}

#[test]
fn bad_input_is_refused_with_what_is_wrong() {
    let rig = Rig::verged();
    let (left, right) = rig.matches(30, 6);
    let f = fundamental_8point(&left, &right).unwrap();
    let run = |l: &[Point2<f64>], r: &[Point2<f64>], f: &Matrix3<f64>, size, threshold| {
        rectify_uncalibrated(l, r, f, size, threshold).unwrap_err()
    };

    for threshold in [0.0, -1.0, f64::NAN] {
        let e = run(&left, &right, &f, SIZE, threshold);
        assert!(
            matches!(e, UncalibratedRectifyError::InvalidThreshold(_)),
            "{e}"
        );
        assert!(e.to_string().contains("threshold"), "{e}");
    }
    assert_eq!(
        run(&left, &right, &f, (0, 768), 1.0),
        UncalibratedRectifyError::InvalidImageSize {
            width: 0,
            height: 768
        }
    );
    assert_eq!(
        run(&left, &right[1..], &f, SIZE, 1.0),
        UncalibratedRectifyError::MismatchedLengths {
            left: 30,
            right: 29
        }
    );
    let mut bad = left.clone();
    bad[3].y = f64::NAN;
    let e = run(&bad, &right, &f, SIZE, 1.0);
    assert_eq!(
        e,
        UncalibratedRectifyError::NonFinite("the left image's points")
    );
    let mut bad_f = f;
    bad_f[(1, 2)] = f64::INFINITY;
    let e = run(&left, &right, &bad_f, SIZE, 1.0);
    assert_eq!(
        e,
        UncalibratedRectifyError::NonFinite("the fundamental matrix")
    );
    let e = run(&left[..2], &right[..2], &f, SIZE, 1.0);
    assert!(
        matches!(
            e,
            UncalibratedRectifyError::TooFewPoints {
                got: 2,
                needed: 3,
                ..
            }
        ),
        "{e}"
    );

    // F of the wrong rank: full rank, rank 1, zero.
    let rank_one = Vector3::new(1.0, 2.0, 3.0) * Vector3::new(0.5, -1.0, 2.0).transpose();
    for (matrix, rank) in [
        (Matrix3::identity(), 3),
        (rank_one, 1),
        (Matrix3::zeros(), 0),
    ] {
        let e = run(&left, &right, &matrix, SIZE, 1.0);
        assert!(
            matches!(e, UncalibratedRectifyError::FundamentalRank { rank: r, .. } if r == rank),
            "{e}"
        );
        assert!(e.to_string().contains("rank 2"), "{e}");
    }

    // Every point far off its epipolar line: none left to fit.
    let shifted: Vec<_> = right.iter().map(|p| Point2::new(p.x, p.y + 25.0)).collect();
    let e = run(&left, &shifted, &f, SIZE, 2.0);
    assert!(
        matches!(e, UncalibratedRectifyError::TooFewPoints { got: 0, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("epipolar"), "{e}");
}

#[test]
fn points_on_one_line_are_refused() {
    let rig = Rig::verged();
    let (left, right) = rig.matches(30, 7);
    let f = fundamental_8point(&left, &right).unwrap();
    // A line of the scene seen by both cameras.
    let (start, step) = (Point3::new(-0.8, -0.3, 3.0), Vector3::new(0.05, 0.02, 0.03));
    let (line_left, line_right): (Vec<_>, Vec<_>) = (0..20)
        .map(|k| {
            let p = start + step * f64::from(k);
            (
                rig.left.project(&p).unwrap(),
                rig.right.project(&(rig.right_from_left * p)).unwrap(),
            )
        })
        .unzip();
    let e = rectify_uncalibrated(&line_left, &line_right, &f, SIZE, 1.0).unwrap_err();
    assert_eq!(e, UncalibratedRectifyError::Collinear { count: 20 });
    assert!(e.to_string().contains("one line"), "{e}");
    // Nor do they give the fundamental matrix to start from.
    let e = find_fundamental(&line_left, &line_right, &RobustOptions::ransac(1.0)).unwrap_err();
    assert!(matches!(e, GeometryError::Degenerate(_)), "{e}");
    assert!(e.to_string().contains("one line"), "{e}");
    // Three copies of one point are as undetermined.
    let same = vec![left[0]; 3];
    let same_right = vec![right[0]; 3];
    let e = rectify_uncalibrated(&same, &same_right, &f, SIZE, 1.0).unwrap_err();
    assert_eq!(e, UncalibratedRectifyError::Collinear { count: 3 });
}

#[test]
fn cameras_looking_along_their_baseline_are_refused() {
    // The right camera 30 cm ahead of the left one: both epipoles near the image centre.
    let rig = Rig {
        right_from_left: Isometry3::from_parts(
            Translation3::new(0.01, 0.0, -0.3),
            UnitQuaternion::from_euler_angles(0.0, 0.02, 0.0),
        ),
        ..Rig::verged()
    };
    let (left, right) = rig.matches(40, 8);
    let f = fundamental_8point(&left, &right).unwrap();
    let e = rectify_uncalibrated(&left, &right, &f, SIZE, 1.0).unwrap_err();
    assert!(
        matches!(e, UncalibratedRectifyError::EpipoleInImage { .. }),
        "{e}"
    );
}

#[test]
fn garbage_input_gives_an_answer_or_an_error_never_a_panic() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let value = |rng: &mut ChaCha8Rng| match rng.random_range(0..8) {
        0 => 0.0,
        1 => 1e300,
        2 => -1e-300,
        _ => rng.random_range(-2000.0..2000.0),
    };
    for _ in 0..300 {
        let n = rng.random_range(0..12);
        let left: Vec<_> = (0..n)
            .map(|_| Point2::new(value(&mut rng), value(&mut rng)))
            .collect();
        let right: Vec<_> = (0..n)
            .map(|_| Point2::new(value(&mut rng), value(&mut rng)))
            .collect();
        let mut f = Matrix3::from_fn(|_, _| value(&mut rng));
        if rng.random_bool(0.5) {
            // Rank 2, so that the search gets past the rank check.
            f = Vector3::from_fn(|_, _| value(&mut rng)).cross_matrix() * f;
        }
        let size = (rng.random_range(0..3000), rng.random_range(0..3000));
        let threshold = value(&mut rng);
        if let Ok(result) = rectify_uncalibrated(&left, &right, &f, size, threshold) {
            assert!(
                result
                    .rectified_left_from_image_left
                    .iter()
                    .chain(result.rectified_right_from_image_right.iter())
                    .all(|v| v.is_finite())
            );
        }
    }
}
