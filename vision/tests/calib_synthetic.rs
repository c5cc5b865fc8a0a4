//! Mono and stereo calibration against ground truth: board corners projected through
//! known cameras (plumb_bob, rational_polynomial, equidistant) with seeded Gaussian
//! pixel noise, about one view in ten corrupted (blur, a moving target, misdetected
//! corners), and the degenerate inputs the solver must refuse.

use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stereocal_vision::calib::{
    CalibError, FixedParameters, MonoCalibration, MonoOptions, RejectionReason, StereoOptions,
    StereoView, View, calibrate_mono, calibrate_stereo, epipolar_distances, essential_matrix,
    fundamental_matrix,
};
use stereocal_vision::camera::{CameraModel, Distortion, DistortionModel, Intrinsics};

const WIDTH: u32 = 1024;
const HEIGHT: u32 = 768;
const NOISE: f64 = 0.05;
const VIEWS: usize = 25;
/// Views corrupted in every session, and how.
const BLURRED: usize = 4;
const MOVING: usize = 13;
const MISDETECTED: usize = 21;

fn board() -> Vec<Point3<f64>> {
    (0..10)
        .flat_map(|r| (0..14).map(move |c| Point3::new(c as f64 * 0.025, r as f64 * 0.025, 0.0)))
        .collect()
}

fn plumb_bob() -> CameraModel {
    CameraModel {
        width: WIDTH,
        height: HEIGHT,
        intrinsics: Intrinsics {
            fx: 880.0,
            fy: 884.5,
            cx: 517.3,
            cy: 379.8,
        },
        distortion: Distortion::PlumbBob {
            coeffs: [-0.28, 0.11, 0.0009, -0.0006, -0.02],
        },
    }
}

fn rational() -> CameraModel {
    CameraModel {
        distortion: Distortion::RationalPolynomial {
            coeffs: [0.6, -0.1, 0.0007, 0.0004, 0.01, 0.9, 0.05, 0.005],
        },
        ..plumb_bob()
    }
}

fn equidistant() -> CameraModel {
    CameraModel {
        width: WIDTH,
        height: HEIGHT,
        intrinsics: Intrinsics {
            fx: 420.0,
            fy: 421.5,
            cx: 509.6,
            cy: 386.2,
        },
        distortion: Distortion::Equidistant {
            coeffs: [0.03, -0.008, 0.004, -0.001],
        },
    }
}

fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    (-2.0 * u.ln()).sqrt() * v.cos()
}

/// A random `camera_from_target`: the board's centre on the ray of a random pixel of
/// `camera`, 0.3 to 0.6 m away, tilted by up to about 45 degrees.
fn random_pose(rng: &mut ChaCha8Rng, camera: &CameraModel) -> Isometry3<f64> {
    let tilt = Vector3::new(
        rng.random_range(-0.8..0.8),
        rng.random_range(-0.8..0.8),
        rng.random_range(-0.5..0.5),
    );
    let rotation = UnitQuaternion::from_scaled_axis(tilt);
    let centre = Vector3::new(0.1625, 0.1125, 0.0);
    let pixel = Point2::new(
        rng.random_range(0.0..camera.width as f64),
        rng.random_range(0.0..camera.height as f64),
    );
    let ray = camera.unproject(&pixel).unwrap_or_else(Vector3::z);
    let target_centre_in_camera = ray.normalize() * rng.random_range(0.3..0.6);
    Isometry3::from_parts(
        Translation3::from(target_centre_in_camera - rotation * centre),
        rotation,
    )
}

fn inside(camera: &CameraModel, p: &Point2<f64>) -> bool {
    p.x >= 2.0
        && p.y >= 2.0
        && p.x <= camera.width as f64 - 3.0
        && p.y <= camera.height as f64 - 3.0
}

/// Exact pixels of the board under each camera, or `None` if a corner leaves one image.
fn project_all(
    cameras: &[(&CameraModel, Isometry3<f64>)],
    points: &[Point3<f64>],
) -> Option<Vec<Vec<Point2<f64>>>> {
    cameras
        .iter()
        .map(|(camera, camera_from_target)| {
            points
                .iter()
                .map(|p| {
                    camera
                        .project(&(camera_from_target * p))
                        .filter(|px| inside(camera, px))
                })
                .collect()
        })
        .collect()
}

/// Noise on every corner, and the session's corruption of view `index`.
fn observe(rng: &mut ChaCha8Rng, exact: &[Point2<f64>], index: usize) -> Vec<Point2<f64>> {
    let mut pixels: Vec<Point2<f64>> = exact
        .iter()
        .map(|p| p + nalgebra::Vector2::new(NOISE * gaussian(rng), NOISE * gaussian(rng)))
        .collect();
    match index {
        BLURRED => {
            for p in &mut pixels {
                *p += nalgebra::Vector2::new(1.5 * gaussian(rng), 1.5 * gaussian(rng));
            }
        }
        MOVING => {
            // Motion blur: corners wander along the direction of motion.
            let direction = nalgebra::Vector2::new(0.8, 0.6);
            for p in &mut pixels {
                *p += direction * (1.5 * gaussian(rng));
            }
        }
        MISDETECTED => {
            for i in [5, 40, 97] {
                pixels[i] += nalgebra::Vector2::new(7.0, -5.0);
            }
        }
        _ => {}
    }
    pixels
}

/// A stereo session of `count` pairs, every corner seen by both cameras.
fn stereo_session(
    left: &CameraModel,
    right: &CameraModel,
    right_from_left: &Isometry3<f64>,
    seed: u64,
    count: usize,
) -> Vec<StereoView> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let points = board();
    let mut views = Vec::new();
    while views.len() < count {
        let left_from_target = random_pose(&mut rng, left);
        let Some(exact) = project_all(
            &[
                (left, left_from_target),
                (right, right_from_left * left_from_target),
            ],
            &points,
        ) else {
            continue;
        };
        let index = views.len();
        views.push(StereoView {
            points_in_target: points.clone(),
            left: observe(&mut rng, &exact[0], index),
            right: observe(&mut rng, &exact[1], index),
        });
    }
    views
}

fn mono_session(camera: &CameraModel, seed: u64, count: usize) -> Vec<View> {
    let rig = Isometry3::identity();
    stereo_session(camera, camera, &rig, seed, count)
        .into_iter()
        .map(|v| View {
            points_in_target: v.points_in_target,
            pixels: v.left,
        })
        .collect()
}

/// One camera's views of a stereo session: `pixels` picks its corners.
fn camera_views(session: &[StereoView], pixels: fn(&StereoView) -> &Vec<Point2<f64>>) -> Vec<View> {
    session
        .iter()
        .map(|v| View {
            points_in_target: v.points_in_target.clone(),
            pixels: pixels(v).clone(),
        })
        .collect()
}

/// Largest pixel displacement, over the corners of the views used (the calibrated
/// area), between the truth and the calibration: each corner's true ray projected
/// through the calibration.
fn max_model_error(truth: &CameraModel, calibration: &MonoCalibration, views: &[View]) -> f64 {
    let mut worst: f64 = 0.0;
    for fit in &calibration.views {
        for pixel in &views[fit.index].pixels {
            let ray = truth.unproject(pixel).unwrap();
            let reprojected = calibration.camera.project(&Point3::from(ray)).unwrap();
            worst = worst.max((reprojected - pixel).norm());
        }
    }
    worst
}

fn check_against_truth(
    truth: &CameraModel,
    calibration: &MonoCalibration,
    views: &[View],
    max_area_error: f64,
) {
    let (k, t) = (&calibration.camera.intrinsics, &truth.intrinsics);
    for (name, got, want) in [
        ("fx", k.fx, t.fx),
        ("fy", k.fy, t.fy),
        ("cx", k.cx, t.cx),
        ("cy", k.cy, t.cy),
    ] {
        assert!((got - want).abs() < 0.2, "{name}: {got} vs truth {want}");
    }
    let model_error = max_model_error(truth, calibration, views);
    assert!(
        model_error < max_area_error,
        "calibrated area moved by {model_error} px"
    );
    let rejected: Vec<usize> = calibration.rejected.iter().map(|r| r.index).collect();
    assert_eq!(
        rejected,
        vec![BLURRED, MOVING, MISDETECTED],
        "{:#?}",
        calibration.rejected
    );
    for r in &calibration.rejected {
        let expected_outliers = r.index == MISDETECTED;
        assert_eq!(
            matches!(r.reason, RejectionReason::OutlierCorners { .. }),
            expected_outliers,
            "view {}: {}",
            r.index,
            r.reason
        );
        assert!(!r.reason.to_string().is_empty());
    }
    assert_eq!(calibration.views.len(), views.len() - 3);
    // The RMS corner distance of Gaussian noise is sqrt(2) times its deviation.
    assert!(
        (calibration.rms - NOISE * 2f64.sqrt()).abs() < 0.02,
        "rms {}",
        calibration.rms
    );
    let std = calibration.std_dev.as_ref().unwrap();
    // The focal length error is within four of its standard deviations.
    assert!(
        (k.fx - t.fx).abs() < 4.0 * std.fx,
        "fx off by {} with std {}",
        k.fx - t.fx,
        std.fx
    );
    assert!(std.fx > 0.0 && std.fx < 0.2, "fx std {}", std.fx);
}

/// Calibrates a seeded session of `truth`'s model and checks it against `truth`.
fn calibrates_to_truth(truth: &CameraModel, seed: u64) {
    let views = mono_session(truth, seed, VIEWS);
    let calibration = calibrate_mono(
        &views,
        WIDTH,
        HEIGHT,
        &MonoOptions::new(truth.distortion.model()),
    )
    .unwrap();
    check_against_truth(truth, &calibration, &views, 0.2);
}

#[test]
fn plumb_bob_matches_ground_truth_and_rejects_the_bad_views() {
    calibrates_to_truth(&plumb_bob(), 1);
}

#[test]
fn rational_polynomial_matches_ground_truth_and_rejects_the_bad_views() {
    calibrates_to_truth(&rational(), 2);
}

#[test]
fn equidistant_matches_ground_truth_and_rejects_the_bad_views() {
    calibrates_to_truth(&equidistant(), 3);
}

#[test]
fn fixed_parameters_stay_at_their_values() {
    let mut truth = plumb_bob();
    truth.intrinsics.fy = truth.intrinsics.fx;
    truth.distortion = Distortion::PlumbBob {
        coeffs: [-0.28, 0.11, 0.0, 0.0, 0.0],
    };
    let views = mono_session(&truth, 4, VIEWS);
    let mut guess = truth.clone();
    guess.intrinsics.cx = 512.0;
    guess.intrinsics.cy = 384.0;
    guess.intrinsics.fx = 700.0;
    guess.intrinsics.fy = 700.0;
    let options = MonoOptions {
        fixed: FixedParameters {
            aspect_ratio: true,
            principal_point: true,
            zero_tangential: true,
            distortion: vec![4],
            ..FixedParameters::default()
        },
        guess: Some(guess),
        ..MonoOptions::new(DistortionModel::PlumbBob)
    };
    let calibration = calibrate_mono(&views, WIDTH, HEIGHT, &options).unwrap();
    let camera = &calibration.camera;
    assert_eq!((camera.intrinsics.cx, camera.intrinsics.cy), (512.0, 384.0));
    assert_eq!(camera.intrinsics.fx, camera.intrinsics.fy);
    assert_eq!(&camera.distortion.coeffs()[2..], &[0.0, 0.0, 0.0]);
    let std = calibration.std_dev.unwrap();
    assert_eq!((std.cx, std.cy, std.distortion[4]), (0.0, 0.0, 0.0));
    assert!(std.fx > 0.0 && std.fx == std.fy);
    // A principal point held 5 px off costs accuracy but the fit still holds.
    assert!((camera.intrinsics.fx - truth.intrinsics.fx).abs() < 10.0);
    assert!(calibration.rms < 1.0, "rms {}", calibration.rms);
}

fn rig() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(-0.12, 0.0015, -0.002),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.004, -0.03, 0.006)),
    )
}

fn check_stereo(left: &CameraModel, right: &CameraModel, seed: u64, model: DistortionModel) {
    let truth = rig();
    let session = stereo_session(left, right, &truth, seed, VIEWS);
    let left_calibration = calibrate_mono(
        &camera_views(&session, |v| &v.left),
        WIDTH,
        HEIGHT,
        &MonoOptions::new(model),
    )
    .unwrap();
    let right_calibration = calibrate_mono(
        &camera_views(&session, |v| &v.right),
        WIDTH,
        HEIGHT,
        &MonoOptions::new(model),
    )
    .unwrap();
    for refine_intrinsics in [false, true] {
        let stereo = calibrate_stereo(
            &left_calibration.camera,
            &right_calibration.camera,
            &session,
            &StereoOptions {
                refine_intrinsics,
                ..StereoOptions::default()
            },
        )
        .unwrap();
        let rotation_error = stereo
            .right_from_left
            .rotation
            .angle_to(&truth.rotation)
            .to_degrees();
        let translation_error =
            (stereo.right_from_left.translation.vector - truth.translation.vector).norm();
        assert!(
            rotation_error < 0.05,
            "rotation off by {rotation_error} deg"
        );
        assert!(
            translation_error < 0.3e-3,
            "translation off by {translation_error} m"
        );
        let rejected: Vec<usize> = stereo.rejected.iter().map(|r| r.index).collect();
        assert_eq!(
            rejected,
            vec![BLURRED, MOVING, MISDETECTED],
            "{:#?}",
            stereo.rejected
        );
        assert!(
            (stereo.rms - NOISE * 2f64.sqrt()).abs() < 0.02,
            "rms {}",
            stereo.rms
        );
        // The epipolar error is the noise's, as with the true cameras.
        let true_f = fundamental_matrix(left, right, &essential_matrix(&truth));
        let true_epipolar: Vec<f64> = stereo
            .pairs
            .iter()
            .flat_map(|p| {
                let pair = &session[p.index];
                epipolar_distances(left, right, &true_f, &pair.left, &pair.right)
            })
            .collect();
        let true_rms =
            (true_epipolar.iter().map(|d| d * d).sum::<f64>() / true_epipolar.len() as f64).sqrt();
        assert!(
            (stereo.epipolar_rms - true_rms).abs() < 0.05 * true_rms,
            "epipolar rms {} against {true_rms} with the true cameras",
            stereo.epipolar_rms
        );
        for pair in &stereo.pairs {
            assert!(pair.rms < 3.0 * NOISE, "{pair:?}");
        }
        let e = stereo.essential;
        let t = stereo.right_from_left.translation.vector;
        assert!((t.transpose() * e).norm() < 1e-12);
        assert_eq!(stereo.fundamental[(2, 2)], 1.0);
    }
}

#[test]
fn stereo_plumb_bob_matches_ground_truth() {
    let mut right = plumb_bob();
    right.intrinsics = Intrinsics {
        fx: 875.0,
        fy: 876.0,
        cx: 505.2,
        cy: 390.1,
    };
    check_stereo(&plumb_bob(), &right, 5, DistortionModel::PlumbBob);
}

#[test]
fn stereo_equidistant_matches_ground_truth() {
    let mut right = equidistant();
    right.intrinsics.cx = 515.0;
    check_stereo(&equidistant(), &right, 6, DistortionModel::Equidistant);
}

#[test]
fn too_few_views_say_how_many_are_needed() {
    let views: Vec<View> = mono_session(&plumb_bob(), 7, VIEWS)
        .into_iter()
        .take(2)
        .collect();
    let error = calibrate_mono(
        &views,
        WIDTH,
        HEIGHT,
        &MonoOptions::new(DistortionModel::PlumbBob),
    )
    .unwrap_err();
    assert!(
        matches!(
            error,
            CalibError::TooFewViews {
                usable: 2,
                needed: 3,
                ..
            }
        ),
        "{error}"
    );
    assert!(error.to_string().contains("at least 3"), "{error}");
}

#[test]
fn fronto_parallel_views_are_refused_with_advice() {
    let camera = plumb_bob();
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let points = board();
    let views: Vec<View> = (0..12)
        .map(|i| {
            let pose = Isometry3::from_parts(
                Translation3::new(-0.15 + 0.01 * i as f64, -0.1, 0.5 + 0.02 * i as f64),
                UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.05 * i as f64)),
            );
            let pixels = points
                .iter()
                .map(|p| {
                    camera.project(&(pose * p)).unwrap()
                        + nalgebra::Vector2::new(
                            NOISE * gaussian(&mut rng),
                            NOISE * gaussian(&mut rng),
                        )
                })
                .collect();
            View {
                points_in_target: points.clone(),
                pixels,
            }
        })
        .collect();
    let error = calibrate_mono(
        &views,
        WIDTH,
        HEIGHT,
        &MonoOptions::new(DistortionModel::PlumbBob),
    )
    .unwrap_err();
    assert!(
        matches!(error, CalibError::FrontoParallel { .. }),
        "{error}"
    );
    assert!(error.to_string().contains("tilt the target"), "{error}");
}

#[test]
fn malformed_views_are_named() {
    let mut views = mono_session(&plumb_bob(), 9, VIEWS);
    views[3].pixels.pop();
    let error = calibrate_mono(
        &views,
        WIDTH,
        HEIGHT,
        &MonoOptions::new(DistortionModel::PlumbBob),
    )
    .unwrap_err();
    assert!(
        matches!(error, CalibError::MismatchedView { view: 3, .. }),
        "{error}"
    );
    let mut views = mono_session(&plumb_bob(), 9, VIEWS);
    views[5].pixels[0].x = f64::NAN;
    let error = calibrate_mono(
        &views,
        WIDTH,
        HEIGHT,
        &MonoOptions::new(DistortionModel::PlumbBob),
    )
    .unwrap_err();
    assert_eq!(error, CalibError::NonFinite { view: 5 });
    let mut views = mono_session(&plumb_bob(), 9, VIEWS);
    views[1].points_in_target[2].z = 0.01;
    let error = calibrate_mono(
        &views,
        WIDTH,
        HEIGHT,
        &MonoOptions::new(DistortionModel::PlumbBob),
    )
    .unwrap_err();
    assert_eq!(error, CalibError::NonPlanarTarget { view: 1 });
}

#[test]
fn without_rejection_every_view_is_used() {
    let views = mono_session(&plumb_bob(), 10, VIEWS);
    let options = MonoOptions {
        rejection: None,
        ..MonoOptions::new(DistortionModel::PlumbBob)
    };
    let calibration = calibrate_mono(&views, WIDTH, HEIGHT, &options).unwrap();
    assert!(calibration.rejected.is_empty());
    assert_eq!(calibration.views.len(), VIEWS);
    // The bad views then dominate the error.
    let worst = calibration
        .views
        .iter()
        .max_by(|a, b| a.rms.total_cmp(&b.rms))
        .unwrap();
    assert!([BLURRED, MOVING, MISDETECTED].contains(&worst.index));
}
