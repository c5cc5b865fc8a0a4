//! IPPE, infinitesimal plane-based pose estimation (Collins and Bartoli 2014).
//!
//! The pose of a planar target in closed form, from the homography between its plane and
//! the image: the homography's Jacobian at the target's centroid fixes the rotation up to
//! the planar ambiguity (a reflection of the plane's tilt about the line of sight), so IPPE
//! returns both poses, ranked by reprojection error. When the two errors are close, the
//! image does not say which pose is right.

use nalgebra::{
    Isometry3, Matrix2, Matrix3, Point2, Point3, Rotation3, SymmetricEigen, Translation3,
    UnitQuaternion, Vector2, Vector3,
};

use super::{PnpError, check_solver_input};
use crate::geometry::homography_dlt;

/// Largest accepted ratio of the target points' RMS distance to their best-fit plane over
/// their RMS spread along the plane's main direction: room for a slightly warped board,
/// none for a 3D target.
const MAX_RELATIVE_THICKNESS: f64 = 1e-3;
/// Ratio of the smaller in-plane spread over the larger below which the points are taken
/// to lie on one line.
const MIN_RELATIVE_WIDTH: f64 = 1e-9;
/// Spread below which the points are taken to coincide, relative to their distance
/// from the origin of the target frame.
const MIN_RELATIVE_SPREAD: f64 = 1e-12;

/// IPPE's two poses, best (least reprojection error) first.
///
/// Both map target points to the camera frame (`camera_from_target`). Errors are RMS over
/// the points of the Euclidean distance, on the camera's `z = 1` plane, between a point's
/// projection and its normalized image point (normalized image units, not pixels).
///
/// When the second pose puts a target point at or behind the camera (depth `<= 0`), it is
/// not a pose: `second` is then a copy of `best` and `second_rms` is `f64::INFINITY`. When
/// the target's plane is perpendicular to the line of sight through its centroid, the
/// ambiguity vanishes and the two poses coincide: `second` then equals `best` (to
/// rounding) and `second_rms` equals `best_rms`.
///
/// Close errors (`second_rms / best_rms` near 1) mean the image does not tell the poses
/// apart: typically a small or distant target seen nearly face-on.
#[derive(Clone, Debug, PartialEq)]
pub struct IppeSolutions {
    /// The pose with the least reprojection error.
    pub best: Isometry3<f64>,
    /// Its RMS reprojection error, normalized image units.
    pub best_rms: f64,
    /// The other pose of the planar ambiguity.
    pub second: Isometry3<f64>,
    /// Its RMS reprojection error, normalized image units; infinite when it is not a pose.
    pub second_rms: f64,
}

/// Both poses of a planar target; n >= 4 coplanar target points in any plane (not only
/// z = 0); errors in normalized image units (RMS over points of the Euclidean reprojection
/// distance on the z = 1 plane).
///
/// `target_points` are in the target frame (metres); `normalized` are their undistorted
/// normalized image points `(X/Z, Y/Z)`, in the same order. Points off the best-fit plane
/// by up to 1e-3 of the target's extent (a warped board) are accepted and taken as on it.
///
/// The poses are exact for exact data (to rounding, about 1e-12), with one exception: when
/// the plane is nearly perpendicular to the line of sight through its centroid, the
/// Jacobian IPPE reads the tilt from changes only to second order with it, so the tilt is
/// known to about the square root of rounding (1e-8 radians).
///
/// Errors: [`PnpError::MismatchedLengths`], [`PnpError::TooFewPoints`] (fewer than 4),
/// [`PnpError::NonFinite`], [`PnpError::Degenerate`] (points coincident, on one line, not
/// coplanar, or not determining a homography: three of four on one line),
/// [`PnpError::NoSolution`] (numerical failure: the homography's Jacobian vanishes or all
/// image points coincide), [`PnpError::BehindCamera`] (neither pose puts every point in
/// front of the camera).
pub fn ippe(
    target_points: &[Point3<f64>],
    normalized: &[Point2<f64>],
) -> Result<IppeSolutions, PnpError> {
    check_solver_input(target_points, normalized, 4)?;
    let plane_from_target = plane_frame(target_points)?;
    let in_plane: Vec<Point2<f64>> = target_points
        .iter()
        .map(|p| (plane_from_target * p).xy())
        .collect();
    // The solver reads the image of the plane's origin from H scaled to H[(2, 2)] = 1:
    // a homography taking that origin to infinity is refused like a degenerate one.
    let plane_to_image = homography_dlt(&in_plane, normalized)
        .ok()
        .filter(|h| h[(2, 2)] == 1.0)
        .ok_or_else(|| {
            PnpError::Degenerate(
                "the points do not determine a plane-to-image homography \
                 (three of four points on one line?)"
                    .into(),
            )
        })?;
    let [first, second] = camera_from_plane_rotations(&plane_to_image)?;
    let pose = |camera_from_plane: Rotation3<f64>| {
        let rotation =
            UnitQuaternion::from_rotation_matrix(&camera_from_plane) * plane_from_target.rotation;
        let translation = translation_for(&rotation, target_points, normalized)?;
        Ok::<_, PnpError>(Isometry3::from_parts(
            Translation3::from(translation),
            rotation,
        ))
    };
    rank(pose(first)?, pose(second)?, target_points, normalized)
}

/// The frame of the target's best-fit plane: origin at the centroid, z along the plane's
/// normal, x along the points' main direction. Refuses points that coincide, lie on one
/// line, or are not coplanar.
fn plane_frame(target_points: &[Point3<f64>]) -> Result<Isometry3<f64>, PnpError> {
    let n = target_points.len() as f64;
    let centroid = target_points
        .iter()
        .fold(Vector3::zeros(), |sum, p| sum + p.coords)
        / n;
    let scatter = target_points.iter().fold(Matrix3::zeros(), |sum, p| {
        let d = p.coords - centroid;
        sum + d * d.transpose()
    });
    let eigen = SymmetricEigen::new(scatter);
    let mut order = [0, 1, 2];
    order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
    let [major, minor, normal] = order;
    let spread = |axis: usize| (eigen.eigenvalues[axis].max(0.0) / n).sqrt();
    let largest_coordinate = target_points
        .iter()
        .flat_map(|p| p.coords.iter().map(|v| v.abs()))
        .fold(0.0, f64::max);
    if spread(major) <= MIN_RELATIVE_SPREAD * largest_coordinate.max(f64::MIN_POSITIVE) {
        return Err(PnpError::Degenerate("all target points coincide".into()));
    }
    if spread(minor) <= MIN_RELATIVE_WIDTH * spread(major) {
        return Err(PnpError::Degenerate("all points on one line".into()));
    }
    let thickness = spread(normal) / spread(major);
    if thickness > MAX_RELATIVE_THICKNESS {
        return Err(PnpError::Degenerate(format!(
            "target points are not coplanar: their RMS distance to the best-fit plane is \
             {thickness:.1e} of their spread, at most {MAX_RELATIVE_THICKNESS:.0e} is accepted"
        )));
    }
    let x = eigen.eigenvectors.column(major).into_owned();
    let y = eigen.eigenvectors.column(minor).into_owned();
    let target_from_plane_rotation = Matrix3::from_columns(&[x, y, x.cross(&y)]);
    let plane_from_target = UnitQuaternion::from_rotation_matrix(
        &Rotation3::from_matrix_unchecked(target_from_plane_rotation.transpose()),
    );
    Ok(Isometry3::from_parts(
        Translation3::from(-(plane_from_target * centroid)),
        plane_from_target,
    ))
}

/// IPPE's two rotations `camera_from_plane` from the plane-to-image homography of a plane
/// frame centred on the target's centroid.
///
/// With `v` the image of the centroid and `R_v` a rotation taking the optical axis to the
/// ray through `v`, the homography's Jacobian at the centroid is `J = B R~ / depth`, where
/// `B` is the upper-left 2x2 block of `[I | -v] R_v` and `R~` the upper-left 2x2 block of
/// `R_v^T R`. So `R~` is `B^-1 J` scaled to a largest singular value of 1, and the
/// rotation's first two columns are `R_v [R~; ±b^T]`, `b` completing `R~`'s columns to unit
/// vectors: the sign of `b` is the planar ambiguity.
fn camera_from_plane_rotations(h: &Matrix3<f64>) -> Result<[Rotation3<f64>; 2], PnpError> {
    let v = Vector2::new(h[(0, 2)], h[(1, 2)]);
    let jacobian = Matrix2::new(
        h[(0, 0)] - h[(2, 0)] * v.x,
        h[(0, 1)] - h[(2, 1)] * v.x,
        h[(1, 0)] - h[(2, 0)] * v.y,
        h[(1, 1)] - h[(2, 1)] * v.y,
    );
    let r_v = rotation_from_optical_axis_to(&Vector3::new(v.x, v.y, 1.0).normalize());
    let b = r_v.fixed_view::<2, 2>(0, 0) - v * r_v.fixed_view::<1, 2>(2, 0);
    let a = b
        .try_inverse()
        .ok_or_else(|| PnpError::NoSolution("singular centroid ray basis".into()))?
        * jacobian;
    let gamma = largest_singular_value(&a);
    if !(gamma > 0.0 && gamma.is_finite()) {
        return Err(PnpError::NoSolution(
            "the homography's Jacobian at the target's centroid vanishes".into(),
        ));
    }
    let r_tilde = a / gamma;
    let (c0, c1) = (r_tilde.column(0), r_tilde.column(1));
    let (b0, b1) = completion(c0.norm_squared(), c1.norm_squared(), c0.dot(&c1));
    let rotation = |sign: f64| {
        let x = Vector3::new(c0.x, c0.y, sign * b0);
        let y = Vector3::new(c1.x, c1.y, sign * b1);
        Rotation3::from_matrix_unchecked(r_v * orthonormal_frame(&x, &y))
    };
    Ok([rotation(1.0), rotation(-1.0)])
}

/// The third components `(b0, b1)` that make the columns of a 2x2 block with largest
/// singular value 1 (squared norms `n0`, `n1`, dot product `dot`) orthonormal 3-vectors,
/// up to a common sign.
///
/// Both components vanish, and the two poses coincide, when the block is itself a
/// rotation (the plane perpendicular to the line of sight through its centroid): rounding can then make `1 - n` slightly negative,
/// which is clamped to zero rather than allowed to give a NaN. The larger component comes
/// from its norm, the smaller from orthogonality, which keeps it exact when it is small.
fn completion(n0: f64, n1: f64, dot: f64) -> (f64, f64) {
    let (s0, s1) = ((1.0 - n0).max(0.0), (1.0 - n1).max(0.0));
    if s0 >= s1 {
        let b0 = s0.sqrt();
        (b0, if b0 > 0.0 { -dot / b0 } else { 0.0 })
    } else {
        let b1 = s1.sqrt();
        (if b1 > 0.0 { -dot / b1 } else { 0.0 }, b1)
    }
}

/// The rotation matrix with first two columns along `x` and `y` (nearly orthonormal), by
/// Gram-Schmidt.
fn orthonormal_frame(x: &Vector3<f64>, y: &Vector3<f64>) -> Matrix3<f64> {
    let x = x.normalize();
    let y = (y - x * x.dot(y)).normalize();
    Matrix3::from_columns(&[x, y, x.cross(&y)])
}

/// The smallest rotation taking the optical axis `(0, 0, 1)` to the unit vector `u`, which
/// points forward (`u.z > 0`), by Rodrigues' formula.
fn rotation_from_optical_axis_to(u: &Vector3<f64>) -> Matrix3<f64> {
    let k = Vector3::new(-u.y, u.x, 0.0).cross_matrix();
    Matrix3::identity() + k + k * k / (1.0 + u.z)
}

/// The largest singular value of a 2x2 matrix, in closed form.
fn largest_singular_value(a: &Matrix2<f64>) -> f64 {
    let ata = a.transpose() * a;
    let half_trace = 0.5 * (ata[(0, 0)] + ata[(1, 1)]);
    let half_gap = (0.25 * (ata[(0, 0)] - ata[(1, 1)]).powi(2) + ata[(0, 1)].powi(2)).sqrt();
    (half_trace + half_gap).sqrt()
}

/// The translation that, with `rotation`, best aligns each camera-frame point with its
/// image ray: linear least squares on `x - u z = 0` and `y - v z = 0`.
fn translation_for(
    rotation: &UnitQuaternion<f64>,
    target_points: &[Point3<f64>],
    normalized: &[Point2<f64>],
) -> Result<Vector3<f64>, PnpError> {
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    for (p, q) in target_points.iter().zip(normalized) {
        let rotated = rotation * p.coords;
        let rows = [Vector3::new(1.0, 0.0, -q.x), Vector3::new(0.0, 1.0, -q.y)];
        for row in rows {
            ata += row * row.transpose();
            atb -= row * row.dot(&rotated);
        }
    }
    ata.cholesky()
        .map(|c| c.solve(&atb))
        .filter(|t| t.iter().all(|v| v.is_finite()))
        .ok_or_else(|| PnpError::NoSolution("all image points coincide".into()))
}

/// A pose's RMS reprojection error on the `z = 1` plane, or the number of points it puts
/// at or behind the camera (0 when the error is not finite).
fn reprojection_rms(
    pose: &Isometry3<f64>,
    target_points: &[Point3<f64>],
    normalized: &[Point2<f64>],
) -> Result<f64, usize> {
    let mut behind = 0;
    let mut sum = 0.0;
    for (p, q) in target_points.iter().zip(normalized) {
        let c = pose * p;
        if c.z > 0.0 {
            sum += (c.xy() / c.z - q).norm_squared();
        } else {
            behind += 1;
        }
    }
    let rms = (sum / target_points.len() as f64).sqrt();
    match behind {
        0 if rms.is_finite() => Ok(rms),
        _ => Err(behind),
    }
}

/// Orders the two poses by reprojection error; a pose with points behind the camera is
/// replaced by the other (see [`IppeSolutions`]).
fn rank(
    a: Isometry3<f64>,
    b: Isometry3<f64>,
    target_points: &[Point3<f64>],
    normalized: &[Point2<f64>],
) -> Result<IppeSolutions, PnpError> {
    let finite = |pose: &Isometry3<f64>| {
        pose.rotation.coords.iter().all(|v| v.is_finite())
            && pose.translation.vector.iter().all(|v| v.is_finite())
    };
    if !finite(&a) || !finite(&b) {
        return Err(PnpError::NoSolution("non-finite pose".into()));
    }
    let both = |best, best_rms, second, second_rms| IppeSolutions {
        best,
        best_rms,
        second,
        second_rms,
    };
    match (
        reprojection_rms(&a, target_points, normalized),
        reprojection_rms(&b, target_points, normalized),
    ) {
        (Ok(ea), Ok(eb)) if ea <= eb => Ok(both(a, ea, b, eb)),
        (Ok(ea), Ok(eb)) => Ok(both(b, eb, a, ea)),
        (Ok(ea), Err(_)) => Ok(both(a, ea, a, f64::INFINITY)),
        (Err(_), Ok(eb)) => Ok(both(b, eb, b, f64::INFINITY)),
        (Err(ca), Err(cb)) if ca == 0 || cb == 0 => {
            Err(PnpError::NoSolution("non-finite reprojection error".into()))
        }
        (Err(ca), Err(cb)) => Err(PnpError::BehindCamera {
            count: ca.min(cb),
            total: target_points.len(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Unit;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::f64::consts::{FRAC_PI_2, PI, TAU};

    /// A planar problem: target points, their exact normalized images, the true pose.
    struct Problem {
        target_points: Vec<Point3<f64>>,
        normalized: Vec<Point2<f64>>,
        camera_from_target: Isometry3<f64>,
    }

    fn rotation_error(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
        (a.rotation.inverse() * b.rotation).angle()
    }

    fn translation_error(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
        (a.translation.vector - b.translation.vector).norm()
    }

    fn project(pose: &Isometry3<f64>, points: &[Point3<f64>]) -> Vec<Point2<f64>> {
        points
            .iter()
            .map(|p| {
                let c = pose * p;
                assert!(c.z > 0.0);
                Point2::from(c.xy() / c.z)
            })
            .collect()
    }

    fn random_rotation(rng: &mut ChaCha8Rng) -> UnitQuaternion<f64> {
        let axis = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        UnitQuaternion::from_scaled_axis(axis.normalize() * rng.random_range(0.0..PI))
    }

    /// Points on a plane of local coordinates `(x, y, 0)`: a board-like grid or random
    /// points, within half-extents of at most 0.5 m.
    fn plane_points(rng: &mut ChaCha8Rng) -> Vec<Point3<f64>> {
        if rng.random_range(0.0..1.0) < 0.5 {
            let (cols, rows) = (rng.random_range(2..10), rng.random_range(2..8));
            let pitch = rng.random_range(0.02..0.1);
            (0..rows)
                .flat_map(|r| (0..cols).map(move |c| (c, r)))
                .map(|(c, r)| Point3::new(c as f64 * pitch, r as f64 * pitch, 0.0))
                .collect()
        } else {
            let n = rng.random_range(4..40);
            let (w, h) = (rng.random_range(0.1..0.5), rng.random_range(0.1..0.5));
            (0..n)
                .map(|_| Point3::new(rng.random_range(-w..w), rng.random_range(-h..h), 0.0))
                .collect()
        }
    }

    /// A plane seen at `tilt` (angle between its normal and the optical axis), 2 to 6 m
    /// away, its target frame placed anywhere relative to the plane.
    fn planar_problem(rng: &mut ChaCha8Rng, tilt: f64) -> Problem {
        let on_plane = plane_points(rng);
        let n = on_plane.len() as f64;
        let centre = on_plane.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / n;
        let axis_angle = rng.random_range(0.0..TAU);
        let tilt_axis = Unit::new_normalize(Vector3::new(axis_angle.cos(), axis_angle.sin(), 0.0));
        let spin = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rng.random_range(0.0..TAU));
        let depth = rng.random_range(2.0..6.0);
        let offset = Vector3::new(
            rng.random_range(-0.3..0.3),
            rng.random_range(-0.3..0.3),
            1.0,
        ) * depth;
        let camera_from_plane = Isometry3::from_parts(
            Translation3::from(offset),
            UnitQuaternion::from_axis_angle(&tilt_axis, tilt) * spin,
        ) * Translation3::from(-centre);
        let target_from_plane = Isometry3::from_parts(
            Translation3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ),
            random_rotation(rng),
        );
        let target_points: Vec<Point3<f64>> =
            on_plane.iter().map(|p| target_from_plane * p).collect();
        let camera_from_target = camera_from_plane * target_from_plane.inverse();
        let normalized = project(&camera_from_target, &target_points);
        Problem {
            target_points,
            normalized,
            camera_from_target,
        }
    }

    #[test]
    fn recovers_exact_planar_poses_as_best() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for trial in 0..300 {
            let tilt = rng.random_range(0.0..70f64.to_radians());
            let problem = planar_problem(&mut rng, tilt);
            let solutions = ippe(&problem.target_points, &problem.normalized).unwrap();
            let truth = &problem.camera_from_target;
            assert!(
                rotation_error(&solutions.best, truth) < 1e-9,
                "trial {trial}: rotation off by {}",
                rotation_error(&solutions.best, truth)
            );
            assert!(
                translation_error(&solutions.best, truth) < 1e-9,
                "trial {trial}: translation off by {}",
                translation_error(&solutions.best, truth)
            );
            assert!(solutions.best_rms < 1e-12, "trial {trial}");
            assert!(solutions.second_rms > solutions.best_rms, "trial {trial}");
        }
    }

    /// A 8 x 6 board of 5 x 4 cm squares, spun by `spin` about the optical axis, its
    /// centroid at `centroid_in_camera`, face-on.
    fn face_on(spin: f64, centroid_in_camera: Vector3<f64>) -> Problem {
        let target_points: Vec<Point3<f64>> = (0..6)
            .flat_map(|r| (0..8).map(move |c| Point3::new(c as f64 * 0.05, r as f64 * 0.04, 0.0)))
            .collect();
        let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), spin);
        let centroid = Vector3::new(0.175, 0.1, 0.0);
        let camera_from_target = Isometry3::from_parts(
            Translation3::from(centroid_in_camera - rotation * centroid),
            rotation,
        );
        let normalized = project(&camera_from_target, &target_points);
        Problem {
            target_points,
            normalized,
            camera_from_target,
        }
    }

    #[test]
    fn face_on_board_on_the_optical_axis_gives_the_true_pose_twice() {
        // The homography's Jacobian is then a scaled rotation and the two poses coincide.
        for spin in [0.0, 0.7, 2.0, -2.5] {
            let problem = face_on(spin, Vector3::new(0.0, 0.0, 2.0));
            let solutions = ippe(&problem.target_points, &problem.normalized).unwrap();
            let truth = &problem.camera_from_target;
            for pose in [&solutions.best, &solutions.second] {
                // The image of a face-on target changes only to second order with its
                // tilt: the closed form knows the tilt to about the square root of
                // rounding, 1e-8 radians.
                assert!(rotation_error(pose, truth) < 1e-6, "spin {spin}");
                assert!(translation_error(pose, truth) < 1e-6, "spin {spin}");
            }
            assert!(solutions.best_rms < 1e-8 && solutions.second_rms < 1e-8);
        }
    }

    #[test]
    fn face_on_board_off_the_optical_axis_has_the_true_pose_as_best() {
        for (spin, centroid) in [
            (0.0, Vector3::new(0.4, -0.3, 3.0)),
            (2.0, Vector3::new(-0.5, 0.2, 1.5)),
        ] {
            let problem = face_on(spin, centroid);
            let solutions = ippe(&problem.target_points, &problem.normalized).unwrap();
            let truth = &problem.camera_from_target;
            assert!(rotation_error(&solutions.best, truth) < 1e-9);
            assert!(translation_error(&solutions.best, truth) < 1e-9);
            assert!(
                solutions
                    .second
                    .rotation
                    .coords
                    .iter()
                    .all(|v| v.is_finite())
            );
            assert!(rotation_error(&solutions.second, truth) > 0.1);
            assert!(solutions.second_rms.is_finite() && solutions.second_rms > 1e-5);
        }
    }

    /// Gaussian noise by the Box-Muller transform.
    fn gaussian(rng: &mut ChaCha8Rng, sigma: f64) -> f64 {
        let u: f64 = rng.random_range(f64::EPSILON..1.0);
        let v: f64 = rng.random_range(0.0..TAU);
        sigma * (-2.0 * u.ln()).sqrt() * v.cos()
    }

    #[test]
    fn small_far_square_is_ambiguous() {
        let square = [
            Point3::new(-0.05, -0.05, 0.0),
            Point3::new(0.05, -0.05, 0.0),
            Point3::new(0.05, 0.05, 0.0),
            Point3::new(-0.05, 0.05, 0.0),
        ];
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut ratios = Vec::new();
        for _ in 0..50 {
            // Nearly face-on: tilted by 5 to 12 degrees about a random axis.
            let axis_angle = rng.random_range(0.0..TAU);
            let tilt_axis =
                Unit::new_normalize(Vector3::new(axis_angle.cos(), axis_angle.sin(), 0.0));
            let truth = Isometry3::from_parts(
                Translation3::new(
                    rng.random_range(-0.5..0.5),
                    rng.random_range(-0.5..0.5),
                    5.0,
                ),
                UnitQuaternion::from_axis_angle(
                    &tilt_axis,
                    rng.random_range(5f64.to_radians()..12f64.to_radians()),
                ) * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rng.random_range(0.0..TAU)),
            );
            // Half a pixel at a focal length of 1000 pixels.
            let normalized: Vec<Point2<f64>> = project(&truth, &square)
                .iter()
                .map(|q| q + Vector2::new(gaussian(&mut rng, 5e-4), gaussian(&mut rng, 5e-4)))
                .collect();
            let solutions = ippe(&square, &normalized).unwrap();
            assert!(rotation_error(&solutions.best, &solutions.second) > 5f64.to_radians());
            assert!(solutions.second_rms.is_finite());
            ratios.push(solutions.second_rms / solutions.best_rms);
        }
        ratios.sort_by(f64::total_cmp);
        let median = ratios[ratios.len() / 2];
        assert!(median < 1.5, "median ratio {median}");
        assert!(ratios.iter().all(|&r| r >= 1.0));
    }

    #[test]
    fn second_pose_behind_the_camera_is_replaced_by_the_best() {
        // A board 3.7 m wide, 1.2 m away: mirroring its tilt about the line of sight
        // swings an edge behind the camera.
        let board: Vec<Point3<f64>> = (0..5)
            .flat_map(|r| (0..5).map(move |c| (c as f64 - 2.0, r as f64 - 2.0)))
            .map(|(x, y)| Point3::new(0.92 * x, 0.92 * y, 0.0))
            .collect();
        let truth = Isometry3::from_parts(
            Translation3::new(0.19, -0.56, 1.21),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.1),
        );
        let normalized = project(&truth, &board);
        let solutions = ippe(&board, &normalized).unwrap();
        assert!(rotation_error(&solutions.best, &truth) < 1e-9);
        assert!(translation_error(&solutions.best, &truth) < 1e-9);
        assert_eq!(solutions.second, solutions.best);
        assert_eq!(solutions.second_rms, f64::INFINITY);
    }

    #[test]
    fn plane_seen_edge_on_gives_its_exact_pose() {
        // The plane through the camera centre: its image is a line, yet the homography
        // (singular) still has a Jacobian at the centroid.
        let board: Vec<Point3<f64>> = (0..4)
            .flat_map(|r| (0..5).map(move |c| Point3::new(c as f64 * 0.1, r as f64 * 0.1, 0.0)))
            .collect();
        let truth = Isometry3::from_parts(
            Translation3::new(-0.2, 0.0, 2.0),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), FRAC_PI_2),
        );
        let normalized = project(&truth, &board);
        assert!(normalized.iter().all(|q| q.y.abs() < 1e-15));
        let solutions = ippe(&board, &normalized).unwrap();
        assert!(rotation_error(&solutions.best, &truth) < 1e-9);
        assert!(translation_error(&solutions.best, &truth) < 1e-9);
    }

    #[test]
    fn refuses_points_off_one_plane() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut problem = planar_problem(&mut rng, 0.5);
        let lift = problem
            .camera_from_target
            .inverse_transform_vector(&Vector3::z())
            * 0.1;
        problem.target_points[0] += lift;
        let result = ippe(&problem.target_points, &problem.normalized);
        assert!(
            matches!(&result, Err(PnpError::Degenerate(m)) if m.contains("not coplanar")),
            "{result:?}"
        );
    }

    #[test]
    fn refuses_collinear_and_coincident_points() {
        let line: Vec<Point3<f64>> = (0..6)
            .map(|i| Point3::new(0.1 * i as f64, 0.2, 1.0))
            .collect();
        let image: Vec<Point2<f64>> = (0..6).map(|i| Point2::new(0.01 * i as f64, 0.0)).collect();
        assert_eq!(
            ippe(&line, &image),
            Err(PnpError::Degenerate("all points on one line".into()))
        );
        let same = vec![Point3::new(0.3, 0.2, 1.0); 6];
        assert!(matches!(ippe(&same, &image), Err(PnpError::Degenerate(_))));
    }

    #[test]
    fn refuses_three_of_four_points_on_one_line() {
        let points = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.1, 0.0, 0.0),
            Point3::new(0.2, 0.0, 0.0),
            Point3::new(0.0, 0.1, 0.0),
        ];
        let truth = Isometry3::translation(0.0, 0.0, 2.0);
        let normalized = project(&truth, &points);
        assert!(matches!(
            ippe(&points, &normalized),
            Err(PnpError::Degenerate(_))
        ));
    }

    #[test]
    fn refuses_bad_input() {
        let points = [Point3::origin(); 3];
        let image = [Point2::origin(); 3];
        assert_eq!(
            ippe(&points, &image),
            Err(PnpError::TooFewPoints { needed: 4, got: 3 })
        );
        assert_eq!(
            ippe(&points, &image[..2]),
            Err(PnpError::MismatchedLengths {
                target_points: 3,
                image_points: 2
            })
        );
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut problem = planar_problem(&mut rng, 0.3);
        problem.normalized[1].x = f64::NAN;
        assert_eq!(
            ippe(&problem.target_points, &problem.normalized),
            Err(PnpError::NonFinite("image points"))
        );
        problem.target_points[0].y = f64::INFINITY;
        assert_eq!(
            ippe(&problem.target_points, &problem.normalized),
            Err(PnpError::NonFinite("target points"))
        );
    }

    #[test]
    fn rotations_stay_proper() {
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        for _ in 0..100 {
            let tilt = rng.random_range(0.0..FRAC_PI_2 * 0.8);
            let problem = planar_problem(&mut rng, tilt);
            let solutions = ippe(&problem.target_points, &problem.normalized).unwrap();
            for pose in [solutions.best, solutions.second] {
                let r = pose.rotation.to_rotation_matrix().into_inner();
                assert!((r.determinant() - 1.0).abs() < 1e-12);
                assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-12);
            }
        }
    }
}
