//! The inputs on which OpenCV's `solvePnP` is known to fail, each answered with a
//! correct pose or a clear refusal, never a wrong pose called success.

use nalgebra::{
    Isometry3, Matrix3, Point2, Point3, Rotation3, Translation3, UnitQuaternion, Vector3,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stereocal_vision::camera::{CameraModel, Distortion, Intrinsics};
use stereocal_vision::pnp::{Correspondences, PnpError, PoseOptions, estimate_pose};

fn pinhole(f: f64, width: u32, height: u32) -> CameraModel {
    CameraModel {
        width,
        height,
        intrinsics: Intrinsics {
            fx: f,
            fy: f,
            cx: f64::from(width) / 2.0,
            cy: f64::from(height) / 2.0,
        },
        distortion: Distortion::none(),
    }
}

fn project(
    camera: &CameraModel,
    pose: &Isometry3<f64>,
    points: &[Point3<f64>],
) -> Vec<Point2<f64>> {
    points
        .iter()
        .map(|p| {
            let c = pose * p;
            camera
                .intrinsics
                .pixel_from_normalized(&nalgebra::Vector2::new(c.x / c.z, c.y / c.z))
        })
        .collect()
}

fn errors(estimate: &Isometry3<f64>, truth: &Isometry3<f64>) -> (f64, f64) {
    let delta = estimate.inverse() * truth;
    (
        delta.rotation.angle().to_degrees(),
        (estimate.translation.vector - truth.translation.vector).norm(),
    )
}

fn board(cols: usize, rows: usize, square: f64) -> Vec<Point3<f64>> {
    (0..rows)
        .flat_map(|r| {
            (0..cols).map(move |c| Point3::new(c as f64 * square, r as f64 * square, 0.0))
        })
        .collect()
}

/// opencv#25094: five points of a cross seen face on; ITERATIVE reports success with a
/// reprojection error of 4.5e18 px.
#[test]
fn a_face_on_cross_gets_its_exact_pose() {
    let camera = pinhole(1000.0, 1000, 1000);
    let points = [
        (0.0, 0.0, 0.0),
        (1.0, 0.0, 0.0),
        (0.0, 0.0, 1.0),
        (-1.0, 0.0, 0.0),
        (0.0, 0.0, -1.0),
    ]
    .map(|(x, y, z)| Point3::new(x, y, z));
    let pixels = [
        (500.0, 500.0),
        (600.0, 500.0),
        (500.0, 400.0),
        (400.0, 500.0),
        (500.0, 600.0),
    ]
    .map(|(u, v)| Point2::new(u, v));
    // The camera looks along +y at 10 units, x to the right and z up.
    let truth = Isometry3::from_parts(
        Translation3::new(0.0, 0.0, 10.0),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(Matrix3::new(
            1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0,
        ))),
    );
    let c = Correspondences::new(&camera, &points, &pixels).unwrap();
    let estimate = estimate_pose(&camera, &c, &PoseOptions::default()).unwrap();
    assert!(estimate.rms_px < 1e-9, "rms {}", estimate.rms_px);
    let (rotation_deg, translation) = errors(&estimate.camera_from_target, &truth);
    assert!(
        rotation_deg < 1e-7 && translation < 1e-8,
        "{rotation_deg} deg, {translation}"
    );
}

/// IPPE returns NaN for a plane parallel to the image while claiming success.
#[test]
fn a_fronto_parallel_board_gets_a_finite_exact_pose() {
    let camera = pinhole(800.0, 1024, 768);
    let points = board(9, 6, 0.03);
    // Board centre on the optical axis, plane parallel to the image.
    let truth = Isometry3::translation(-0.12, -0.075, 0.5);
    let pixels = project(&camera, &truth, &points);
    let c = Correspondences::new(&camera, &points, &pixels).unwrap();
    let estimate = estimate_pose(&camera, &c, &PoseOptions::default()).unwrap();
    assert!(estimate.covariance.iter().all(|v| v.is_finite()));
    let (rotation_deg, translation) = errors(&estimate.camera_from_target, &truth);
    assert!(
        rotation_deg < 1e-6 && translation < 1e-9,
        "{rotation_deg} deg, {translation} m"
    );
}

/// opencv#8813: a small square far away, nearly face on, has two poses that explain
/// noisy pixels almost equally well. With the pixel noise declared, every answer is the
/// right pose (within four standard deviations of its own covariance) or a refusal as
/// ambiguous; both occur.
#[test]
fn the_planar_ambiguity_is_refused_or_resolved_never_guessed() {
    let camera = pinhole(800.0, 1024, 768);
    let half = 0.025;
    let points = [(-half, -half), (half, -half), (half, half), (-half, half)]
        .map(|(x, y)| Point3::new(x, y, 0.0));
    let mut rng = ChaCha8Rng::seed_from_u64(8813);
    // Uniform noise of +-0.5 px has a standard deviation of 0.5 / sqrt(3) px.
    let options = PoseOptions {
        pixel_noise_px: 0.5 / 3f64.sqrt(),
        ..PoseOptions::default()
    };
    let (mut refused, mut resolved) = (0, 0);
    for _ in 0..200 {
        let tilt = Vector3::new(
            rng.random_range(-0.2..0.2),
            rng.random_range(-0.2..0.2),
            rng.random_range(-3.0..3.0),
        );
        let truth = Isometry3::from_parts(
            Translation3::new(
                rng.random_range(-0.3..0.3),
                rng.random_range(-0.2..0.2),
                rng.random_range(1.5..3.0),
            ),
            UnitQuaternion::from_scaled_axis(tilt),
        );
        let pixels: Vec<_> = project(&camera, &truth, &points)
            .into_iter()
            .map(|p| {
                p + nalgebra::Vector2::new(rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5))
            })
            .collect();
        let c = Correspondences::new(&camera, &points, &pixels).unwrap();
        match estimate_pose(&camera, &c, &options) {
            Err(PnpError::Ambiguous { significance, .. }) => {
                assert!(significance < 3.0);
                refused += 1;
            }
            Ok(estimate) => {
                let delta = estimate.camera_from_target.rotation.inverse() * truth.rotation;
                let sigma = estimate
                    .covariance
                    .fixed_view::<3, 3>(3, 3)
                    .symmetric_eigenvalues()
                    .max()
                    .sqrt();
                assert!(
                    delta.angle() < 4.0 * sigma,
                    "pose {:.2} deg from the truth, sigma {:.2} deg, rms {}, ambiguity {:?}",
                    delta.angle().to_degrees(),
                    sigma.to_degrees(),
                    estimate.rms_px,
                    estimate
                        .ambiguity
                        .as_ref()
                        .map(|a| (a.ratio, a.angle.to_degrees(), a.rms_px))
                );
                resolved += 1;
            }
            Err(e) => panic!("unexpected refusal: {e}"),
        }
    }
    assert!(
        refused > 0 && resolved > 0,
        "{refused} refused, {resolved} resolved"
    );
}

/// Points on one line determine no pose.
#[test]
fn collinear_points_are_refused() {
    let camera = pinhole(800.0, 1024, 768);
    let points: Vec<_> = (0..8)
        .map(|i| Point3::new(i as f64 * 0.03, 0.0, 0.0))
        .collect();
    let truth = Isometry3::from_parts(
        Translation3::new(-0.1, 0.0, 0.6),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.2, 0.3, 0.1)),
    );
    let pixels = project(&camera, &truth, &points);
    let c = Correspondences::new(&camera, &points, &pixels).unwrap();
    let refusal = estimate_pose(&camera, &c, &PoseOptions::default()).unwrap_err();
    assert!(matches!(refusal, PnpError::Degenerate(_)), "{refusal}");
    assert!(refusal.to_string().contains("one line"), "{refusal}");
}

/// The pixels of a (non-planar) target behind the camera: no pose in front explains
/// them, and none is returned.
#[test]
fn a_target_behind_the_camera_is_refused() {
    let camera = pinhole(800.0, 1024, 768);
    let mut rng = ChaCha8Rng::seed_from_u64(4854);
    for _ in 0..50 {
        let points: Vec<_> = (0..12)
            .map(|_| {
                Point3::new(
                    rng.random_range(-0.2..0.2),
                    rng.random_range(-0.2..0.2),
                    rng.random_range(-0.2..0.2),
                )
            })
            .collect();
        let behind = Isometry3::from_parts(
            Translation3::new(
                rng.random_range(-0.2..0.2),
                rng.random_range(-0.2..0.2),
                -rng.random_range(1.0..2.0),
            ),
            UnitQuaternion::from_scaled_axis(Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )),
        );
        let pixels = project(&camera, &behind, &points);
        let c = Correspondences::new(&camera, &points, &pixels).unwrap();
        if let Ok(estimate) = estimate_pose(&camera, &c, &PoseOptions::default()) {
            panic!(
                "a pose with rms {} px was returned for a target behind the camera",
                estimate.rms_px
            );
        }
    }
}
